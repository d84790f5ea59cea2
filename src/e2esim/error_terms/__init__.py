"""Error terms: named error sources added to the propagation's error model, in the order a scenario lists them
(its ``error_terms`` section). ``modules``: the shipped terms; ``effects``: their equations; ``wrapped``: the error
model with one more source; ``stage``: how the list joins the chain."""
