"""The atomic writers moved to ``e2esim.atomic`` (the runner's journal writes with them too, and the runner sits
below io). This name stays so that imports written before the move work."""

from e2esim.atomic import atomic_path, write_bytes_atomic, write_text_atomic  # noqa: F401
