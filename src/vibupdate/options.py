"""Every option of the solver, the formulation, the polish and the verification, declared once.

Each `Option` states its name, type, range, default and a one-line doc. Everything that
accepts options reads this table: the option classes (`vibupdate.SolverOptions`,
`FormulationOptions`, `PolishOptions`, `VerifyOptions`) take their defaults from it and
check every value with `check` when constructed (the solver's ``backend`` is a name in the
backend registry, `vibupdate.inverse.backends.BACKENDS`, which tests and plug-ins extend, so
it is checked there and is no case-file key), the case loader (`vibupdate.io.case`) checks
the tables ``[solver]``, ``[formulation]``, ``[polish]`` and ``[verification]`` of a case file
with `problem`, and the option tables of ``docs/case-file.md`` are `markdown_table` of it (a
test holds them equal). So the same value is refused in the same words from Python and from a
case file, e.g. ``solver.step_growth: must be finite and in [1, 100], got 1000``.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass


#: The option tables, in the order of the case file's documentation.
TABLES = ("solver", "formulation", "polish", "verification")


@dataclass(frozen=True)
class Option:
    """One option: ``kind`` is "integer", "number", "string" or "boolean"; numbers lie in
    ``[lower, upper]`` (an end None is unbounded; ``open_lower``/``open_upper`` exclude it) and
    are finite; a string is one of ``choices``; ``optional``: None is allowed (and is then the
    default). ``default_text`` says what the default means where the value alone does not;
    ``in_case_file``: the option is a key of its case-file table."""

    table: str
    name: str
    kind: str
    default: object
    doc: str
    lower: float | None = None
    upper: float | None = None
    open_lower: bool = False
    open_upper: bool = False
    choices: tuple[str, ...] = ()
    optional: bool = False
    default_text: str | None = None
    in_case_file: bool = True

    def expected(self) -> str:
        """What a valid value is: "an integer from 1 to 10000", "finite and in (0, 1)"."""
        if self.kind == "boolean":
            return "true or false"
        if self.kind == "string":
            quoted = [repr(c) for c in self.choices]
            return quoted[0] if len(quoted) == 1 else ", ".join(quoted[:-1]) + " or " + quoted[-1]
        return ("an integer " if self.kind == "integer" else "finite and ") + self.range_text()

    def range_text(self) -> str:
        """The range of a number: "in [1, 100]", "from 1 to 10000", "> 0"."""
        lo, hi = self.lower, self.upper
        if lo is not None and hi is not None:
            if self.kind == "integer":
                return f"from {_num(lo)} to {_num(hi)}"
            return f"in {'(' if self.open_lower else '['}{_num(lo)}, {_num(hi)}{')' if self.open_upper else ']'}"
        if lo is not None:
            return f"{'>' if self.open_lower else '>='} {_num(lo)}"
        if hi is not None:
            return f"{'<' if self.open_upper else '<='} {_num(hi)}"
        return "(any)"

    def refuses(self, value) -> str | None:
        """Why ``value`` is not valid (``"must be ..., got ..."``), None when it is."""
        if value is None and self.optional:
            return None
        if not self._has_kind(value) or not self._in_range(value):
            return f"must be {self.expected()}, got {value!r}"
        return None

    def _has_kind(self, value) -> bool:
        if self.kind == "boolean":
            return isinstance(value, bool)
        if self.kind == "string":
            return isinstance(value, str)
        if self.kind == "integer":
            return isinstance(value, numbers.Integral) and not isinstance(value, bool)
        return finite(value)

    def _in_range(self, value) -> bool:
        if self.kind == "string":
            return value in self.choices
        if self.kind == "boolean":
            return True
        lo, hi = self.lower, self.upper
        if lo is not None and (value <= lo if self.open_lower else value < lo):
            return False
        return not (hi is not None and (value >= hi if self.open_upper else value > hi))

    def default_shown(self) -> str:
        """The default as the case-file documentation shows it."""
        if self.default_text is not None:
            return self.default_text
        if self.kind == "boolean":
            return "true" if self.default else "false"
        if self.kind == "string":
            return f'"{self.default}"'
        return _num(self.default)


def finite(value) -> bool:
    """Whether ``value`` is a real number (not bool) that is finite."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return False
    try:
        return math.isfinite(float(value))
    except (TypeError, ValueError, OverflowError):
        return False


def _num(value) -> str:
    value = float(value)
    if value.is_integer() and abs(value) < 1e7:
        return str(int(value))
    mantissa, _, exponent = f"{value:g}".partition("e")
    return f"{mantissa}e{int(exponent)}" if exponent else mantissa


def _choices(values) -> dict:
    return {"kind": "string", "choices": tuple(values)}


OPTIONS = (
    # -- [solver]: the homotopy (vibupdate.inverse.homotopy.SolverOptions) ---------------------
    Option("solver", "n_lambda", "integer", 1, "the first homotopy step is `1 / n_lambda`; with `step_growth = 1`, "
           "`n_lambda` equal steps from 0 to 1", lower=1, upper=10_000,
           default_text="1: the direct jump, halved only when it fails"),
    Option("solver", "step_growth", "number", 2.0, "factor by which an accepted step lengthens the next one",
           lower=1, upper=100),
    Option("solver", "relaxation_solver", default="piqp", doc="what solves the `lambda = 0` relaxation, a convex QP: "
           '`"piqp"` (IPOPT when PIQP fails) or `"nlp"` (IPOPT)', **_choices(("piqp", "nlp"))),
    Option("solver", "min_step", "number", 1e-3, "smallest step after halving", lower=0, upper=1, open_lower=True),
    Option("solver", "proximal", "number", 1e-6, "proximal weight on intermediate steps, relative to the nominal "
           "objective", lower=0, upper=1),
    Option("solver", "max_iter", "integer", 3000, "IPOPT iterations per solve", lower=1, upper=1_000_000),
    Option("solver", "max_cpu_time", "number", 600.0, "seconds per solve", lower=0, open_lower=True),
    Option("solver", "tol", "number", 1e-10, "IPOPT tolerance", lower=0, upper=1, open_lower=True, open_upper=True),
    Option("solver", "time_budget", "number", 300.0, "seconds the homotopy path may take (the relaxation and every "
           "step); a path that cannot finish in it stops at its last accepted point and the run goes on to the further "
           "starts", lower=0, open_lower=True),
    # -- [formulation]: the first-stage problem (vibupdate.inverse.formulation.options.FormulationOptions)
    # The margins: the first stage itself widens them tenfold, at most twice, when the relaxation
    # proves the boxes exclude every fit (vibupdate.inverse.update.MAX_WIDENINGS), so the range
    # holds 100 (the widest worth stating) widened twice; wider boxes bound nothing.
    Option("formulation", "shape_margin", "number", 1.5, "unmeasured mode entries within "
           "`+- shape_margin * max abs nominal`", lower=1, upper=10_000),
    Option("formulation", "adjunct_margin", "number", 1.5, "adjunct entries within `+- adjunct_margin`",
           lower=1, upper=10_000),
    Option("formulation", "sign_delta", "number", 1e-3, "distance from zero of interlacing sign bounds",
           lower=0, upper=1, open_lower=True, open_upper=True),
    Option("formulation", "length_scale", "number", None, "m, scales rotational entries", lower=0, open_lower=True,
           optional=True, default_text="from the stiffness diagonal, the element length for a uniform beam"),
    Option("formulation", "weighting", default="relative", doc='`"relative"` (each residual ~ relative eigenvalue '
           'error) or `"unit"` (alpha = 1)', **_choices(("relative", "unit"))),
    Option("formulation", "interlacing", "boolean", True, "apply interlacing sign bounds at all"),
    Option("formulation", "reduction", default="auto", doc='`"auto"`, `"none"` or `"craig-bampton"`: solve on a '
           "reduced model that keeps the measured and receptance DOFs physical (see "
           "`vibupdate.inverse.reduction`); results are always computed on the full model",
           **_choices(("auto", "none", "craig-bampton"))),
    Option("formulation", "reduction_modes", "integer", 20, "fixed-interface modes of the reduction", lower=0),
    Option("formulation", "reduction_threshold", "integer", 200, '`"auto"` reduces models with more DOFs than this',
           lower=0),
    # -- [polish]: the refinement after the homotopy (vibupdate.inverse.polish.PolishOptions) --
    Option("polish", "enabled", "boolean", True, "refine the homotopy's answer by bounded least squares of the "
           "distances outside the admissible intervals of the data (docs/polish-and-verification.md)"),
    Option("polish", "max_evaluations", "integer", None, "full-model evaluations of the refinement at most", lower=1,
           optional=True, default_text="100 per parameter plus 100; it normally ends on convergence or a stall long "
                                       "before, and a stop on this limit is a warning"),
    Option("polish", "max_seconds", "number", None, "wall-clock limit of the refinement in seconds", lower=0,
           open_lower=True, optional=True, default_text="none; a stop on it is a warning"),
    Option("polish", "reduced_rounds", "integer", 6, "rounds on a reduced model before the full-model finish, for "
           "models above 400 DOFs (docs/method.md, section 7.2)", lower=0, default_text="6; 0: full model only"),
    Option("polish", "tol", "number", 1e-12, "its convergence tolerance", lower=0, upper=1, open_lower=True,
           open_upper=True),
    # -- [verification]: the checks of the returned model (vibupdate.inverse.verify.VerifyOptions)
    Option("verification", "mac_min", "number", 0.8, "smallest MAC of a measured shape with its declared mode",
           lower=0, upper=1),
    Option("verification", "exact_half_width", "number", 1e-6, "relative half-width of the measurement interval of "
           "a datum known exactly (an interval of zero width): exact data are met to this, not to the last digit "
           "(docs/polish-and-verification.md)", lower=0, upper=1, open_upper=True),
    Option("verification", "frequency_tolerance", "number", 0.01, "relative frequency uncertainty of the "
           "consistency allowance (a case file states it at the top level)", lower=0, upper=1, open_upper=True,
           in_case_file=False),
    Option("verification", "measurement_tolerance", "number", 0.0, "relative half-width of the measurement interval "
           "of a frequency without its own interval (a case file states it at the top level, `frequency_tolerance`)",
           lower=0, upper=1, open_upper=True, in_case_file=False),
    # model-form tolerances: what the model may miss beyond each datum's measurement interval
    # (docs/method.md, "Measurement error and model-form error")
    Option("verification", "natural_tolerance", "number", 0.02, "model-form tolerance of the natural frequencies: "
           "the largest relative miss beyond a frequency's measurement interval", lower=0, upper=1, open_upper=True,
           default_text="0.02: the paper's cantilever, verified, misses one frequency by 1.63 %"),
    Option("verification", "antiresonance_tolerance", "number", 0.02, "model-form tolerance of the antiresonances, "
           "as `natural_tolerance`", lower=0, upper=1, open_upper=True),
    Option("verification", "shape_tolerance", "number", 0.02, "model-form tolerance of the mode shapes: the largest "
           "distance of a shape ratio (normalized at the mode's largest measured entry) beyond its measurement "
           "interval", lower=0, upper=1, open_upper=True),
    Option("verification", "modal_mass_tolerance", "number", 0.05, "model-form tolerance of the modal masses that "
           "mass-normalized shapes measure: the largest relative miss beyond a modal mass's measurement interval",
           lower=0, upper=1, open_upper=True,
           default_text="0.05, chosen, not measured: a modal constant carries the calibration of two transducers and "
           "the fit of a peak, each a few per cent"),
    Option("verification", "diagnose", "boolean", True, "when the answer does not fit the data, rank the groups of "
           "the data (each frequency, each shape, each shape DOF across modes) by how well the model fits without "
           "each, and update again without the worst (docs/method.md, section 7.8)"),
    Option("verification", "suggest", "boolean", True, "when the answer is not verified and the case declares "
           "[[candidate]]s, screen each candidate added to the parameters (a polish from the answer and a "
           "verification each, no full update) and name the best in the report (docs/method.md, section 7.9)"),
)

_BY_NAME = {(o.table, o.name): o for o in OPTIONS}


def declared(table: str, *, case_file: bool = False) -> tuple[Option, ...]:
    """The options of ``table`` in declaration order (with ``case_file``, only its case-file keys)."""
    if table not in TABLES:
        raise ValueError(f"unknown option table {table!r}; tables: {', '.join(TABLES)}")
    return tuple(o for o in OPTIONS if o.table == table and (o.in_case_file or not case_file))


def default(table: str, name: str):
    """The declared default of ``table.name``."""
    return _BY_NAME[(table, name)].default


def problem(table: str, name: str, value) -> str | None:
    """``"table.name: must be ..., got ..."`` when ``value`` is refused, else None."""
    why = _BY_NAME[(table, name)].refuses(value)
    return None if why is None else f"{table}.{name}: {why}"


def check(table: str, options) -> None:
    """Raise ValueError naming the first declared option of ``table`` whose value on
    ``options`` (an option object) is refused, its value and its range."""
    for option in declared(table):
        why = problem(table, option.name, getattr(options, option.name))
        if why is not None:
            raise ValueError(why)


def markdown_table(table: str) -> str:
    """The case-file documentation's table of ``[table]``: key, type, meaning with range and
    default."""
    rows = ["| key | type | meaning |", "|---|---|---|"]
    for o in declared(table, case_file=True):
        limits = "" if o.kind in ("boolean", "string") else f"; {o.range_text()}"
        rows.append(f"| `{o.name}` | {o.kind} | {o.doc}{limits} (default {o.default_shown()}) |")
    return "\n".join(rows)
