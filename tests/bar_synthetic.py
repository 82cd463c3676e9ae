"""Known-truth FRFs of a free-free steel bar tested by roving hammer, for `vibupdate suggest`:
the worked example `vibupdate.examples.bar` (its docstring says what the truth and the model
are), under the name the tests and benchmarks import."""

from vibupdate.examples.bar import *  # noqa: F401,F403
