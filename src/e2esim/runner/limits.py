"""The validation limits moved to ``e2esim.limits`` (beside ``e2esim.errors``: physics checks its inputs against
them too, and physics does not import the runner). This name stays so that imports written before the move work."""

from e2esim.limits import *  # noqa: F403
from e2esim.limits import SPLIT_ADVICE, check_count, check_monte_carlo, check_plain, monte_carlo_bytes, shorten  # noqa: F401
