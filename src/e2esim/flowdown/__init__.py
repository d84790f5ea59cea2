"""Requirements flowed down: the inverse solve (``solve``) and the allocation from the top (``allocate``)."""
