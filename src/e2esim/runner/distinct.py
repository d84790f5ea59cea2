"""``distinct_rows`` moved to ``e2esim.distinct`` (the batched kernels use it too, and physics does not import the
runner). This name stays so that imports written before the move work."""

from e2esim.distinct import distinct_rows  # noqa: F401
