"""What a right answer is, per family of known-truth problems, and the budgets of each outcome.

A family (`Family`) is a maker of problems from a seed and the criteria its runs must meet.
Two kinds of criteria:

* defects (`acceptance.runner.DEFECTS`: a crash, a valid input refused, an answer claiming to
  fit with a datum outside its interval, a determined parameter missed, the truth outside a
  reported range, a report that is not the model's, a damping fit that is not the least squares
  of its ratios or misses exact in-family ratios, negative damping not warned of): none, in
  every family;
* budgets, per family and each on its own: the least share of runs that must end verified
  (``success_min``), the largest share that may end ``not_verified`` (``not_verified_max``:
  strictness is never free, a family that fails to verify spends it), the answers worse than
  the nominal model by the contract's misfit (``worse_max``, `acceptance.judge.misfit`), the
  answers whose misfit exceeds the judge's own least-squares compromise's by more than
  `ABOVE_COMPROMISE` (``above_compromise_max``, where the problem asks for the compromise), and,
  where the data hold a wrong group by construction, the least share of diagnosed runs that
  rank it first (``first_min``).

The judge's excused classes (``not_unique``, ``undetermined_far``) are counted per family and
printed (`summary`), never spent silently. `check` returns every criterion with its measured
value and limit; a test or the benchmark asserts on them.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass

from acceptance import runner as R
from acceptance.judge import FLOOR, Verdict

__all__ = ["Family", "Finding", "FAMILIES", "IN_FAMILY", "PROFILES", "REGRESSION_SEEDS", "NEW_FAMILIES", "check",
           "summary", "profile_jobs", "EXCUSED", "DEFECTS", "SIZE", "SIZE_FAMILIES", "CI_RANDOM", "right",
           "compare"]

#: Failure codes that are defects in every family (`acceptance.runner.DEFECTS`).
DEFECTS = R.DEFECTS
#: The judge's excused classes, counted and printed.
EXCUSED = ("not_unique", "undetermined_far")
#: Budgets of a family whose model holds the truth and whose data admit it: at least 97 % of
#: the runs verified, at most 3 % not verified (the rate the engine held on its held-out seeds
#: 1000-1199: 398 of 400 verified), no answer worse than the nominal model.
IN_FAMILY = dict(success_min=0.97, not_verified_max=0.03, worse_max=0)
#: Budgets of the size families (50-5,000 DOFs, 20-40 parameters): at least 95 % of the runs
#: verified, at most 5 % not verified, no answer worse than the nominal model.
SIZE = dict(success_min=0.95, not_verified_max=0.05, worse_max=0)
#: How far above the misfit of the judge's least-squares compromise a model-form answer may be:
#: within 10 % of a plain least-squares fit's misfit (a relative margin; both misfits are sums of
#: squared distances outside the admissible intervals, `acceptance.judge.misfit`), plus the
#: judge's floor for a compromise that fits every datum.
ABOVE_COMPROMISE = 0.10
#: Least share of the diagnosed runs of the biased-channel family that rank the biased sensor
#: first.
BIASED_FIRST = 0.9


@dataclass(frozen=True)
class Family:
    """A family of problems: ``make(seed)`` draws one; ``meaning`` says what a right answer is
    (the maker's docstring); the budgets of the module docstring (None: not budgeted)."""

    name: str
    make: Callable
    success_min: float | None = None
    not_verified_max: float | None = None
    worse_max: int | None = None
    first_min: float | None = None
    above_compromise_max: int | None = None

    @property
    def meaning(self) -> str:
        return " ".join((self.make.__doc__ or "").split())


@dataclass(frozen=True)
class Finding:
    """One criterion of one family: measured ``value`` against ``limit`` (``ok``), the runs
    counted, and the cases that spent it."""

    family: str
    criterion: str
    value: float
    limit: float
    ok: bool
    runs: int
    cases: tuple = ()

    def line(self) -> str:
        mark = "ok" if self.ok else "FAILED"
        cases = f" ({', '.join(self.cases[:8])}{' ...' if len(self.cases) > 8 else ''})" if self.cases else ""
        return f"{self.family}: {self.criterion} {self.value:g} (limit {self.limit:g}, {self.runs} runs) {mark}{cases}"


def _ids(verdicts) -> tuple:
    return tuple(sorted({f"{v.case_id}[{v.route}]" for v in verdicts}))


def check(verdicts: list[Verdict], families: dict) -> list[Finding]:
    """Every criterion of every family present in ``verdicts`` (module docstring)."""
    by = defaultdict(list)
    for v in verdicts:
        by[v.classes["family"]].append(v)
    out = []
    for name, runs in sorted(by.items()):
        fam = families[name]
        n = len(runs)
        for code in DEFECTS:
            bad = [v for v in runs if code in v.failures]
            out.append(Finding(name, f"defect {code}", len(bad), 0, not bad, n, _ids(bad)))
        if fam.success_min is not None:
            bad = [v for v in runs if not v.success]
            need = math.ceil(fam.success_min * n)
            out.append(Finding(name, "verified runs", n - len(bad), need, n - len(bad) >= need, n, _ids(bad)))
        if fam.not_verified_max is not None:
            bad = [v for v in runs if "not_verified" in v.failures]
            allowed = math.floor(fam.not_verified_max * n)
            out.append(Finding(name, "not_verified runs", len(bad), allowed, len(bad) <= allowed, n, _ids(bad)))
        if fam.worse_max is not None:
            bad = [v for v in runs if "worse_than_nominal" in v.failures]
            out.append(Finding(name, "answers worse than nominal", len(bad), fam.worse_max, len(bad) <= fam.worse_max,
                               n, _ids(bad)))
        if fam.above_compromise_max is not None:
            bad = [v for v in runs if v.compromise and above_compromise(v.compromise)]
            out.append(Finding(name, f"answers over {ABOVE_COMPROMISE:.0%} above the compromise's misfit", len(bad),
                               fam.above_compromise_max, len(bad) <= fam.above_compromise_max, n, _ids(bad)))
        if fam.first_min is not None:
            diagnosed = [v for v in runs if v.diagnosis]
            expected = {v.case_id: v.classes.get("expected_first") for v in runs}
            bad = [v for v in diagnosed if v.diagnosis[0] != expected[v.case_id]]
            share = (len(diagnosed) - len(bad)) / len(diagnosed) if diagnosed else 0.0
            out.append(Finding(name, "wrong group ranked first (share right)", round(share, 3), fam.first_min,
                               share >= fam.first_min, len(diagnosed), _ids(bad)))
    return out


def right(v: Verdict, fam: Family) -> bool:
    """Whether one run gave a right answer by its family's stated meaning: no defect, verified
    where the family budgets the verified share, not worse than nominal and not above the
    compromise where it budgets those, the expected group ranked first where it diagnoses one.
    A model-form or biased-data run may be right without being verified; an in-family run may not."""
    if any(code in v.failures for code in DEFECTS):
        return False
    if fam.success_min is not None and not v.success:
        return False
    if fam.worse_max is not None and "worse_than_nominal" in v.failures:
        return False
    if fam.above_compromise_max is not None and v.compromise and above_compromise(v.compromise):
        return False
    return fam.first_min is None or not v.diagnosis or v.diagnosis[0] == v.classes.get("expected_first")


def compare(these: list[Verdict], those: list[Verdict], families: dict) -> str:
    """Per family present in both: the share of runs verified and the share right (`right`) in
    ``these`` and ``those`` (e.g. held-out and development seeds), and the difference in points
    with its sampling error (two binomial proportions, over problems: a problem's routes are
    not independent draws)."""
    def rates(runs):
        problems = len({v.case_id for v in runs})
        return problems, sum(v.success for v in runs) / len(runs), sum(right(v, families[v.classes["family"]])
                                                                       for v in runs) / len(runs)

    def by_family(verdicts):
        out = defaultdict(list)
        for v in verdicts:
            out[v.classes["family"]].append(v)
        return out

    a, b = by_family(these), by_family(those)
    lines = ["| family | problems | verified % | right % | problems (against) | verified % | right % | "
             "verified difference, points (sampling error) | right difference, points (sampling error) |",
             "|---" * 9 + "|"]
    for name in sorted(set(a) & set(b)):
        (na, va, ra), (nb, vb, rb) = rates(a[name]), rates(b[name])
        diff = [f"{100 * (x - y):+.1f} ({100 * math.sqrt(x * (1 - x) / na + y * (1 - y) / nb):.1f})"
                for x, y in ((va, vb), (ra, rb))]
        lines.append(f"| {name} | {na} | {100 * va:.1f} | {100 * ra:.1f} | {nb} | {100 * vb:.1f} | {100 * rb:.1f} | "
                     f"{diff[0]} | {diff[1]} |")
    return "\n".join(lines)


def above_compromise(found: dict) -> bool:
    """Whether an answer's misfit exceeds the compromise's by more than `ABOVE_COMPROMISE`."""
    return found["misfit"] > found["compromise_misfit"] * (1 + ABOVE_COMPROMISE) + FLOOR


def summary(verdicts: list[Verdict]) -> str:
    """Per family: runs, verified, not verified, and the judge's excused classes."""
    by = defaultdict(list)
    for v in verdicts:
        by[v.classes["family"]].append(v)
    lines = ["| family | runs | verified | not_verified | path failed | worse than nominal | "
             + " | ".join(f"excused {e}" for e in EXCUSED) + " |", "|---" * (6 + len(EXCUSED)) + "|"]
    for name, runs in sorted(by.items()):
        counts = [sum(v.success for v in runs), sum("not_verified" in v.failures for v in runs),
                  sum("path_failed" in v.failures for v in runs), sum("worse_than_nominal" in v.failures for v in runs)]
        counts += [sum(e in v.excused for v in runs) for e in EXCUSED]
        lines.append(f"| {name} | {len(runs)} | " + " | ".join(str(c) for c in counts) + " |")
    for name, runs in sorted(by.items()):
        near = [v.compromise for v in runs if v.compromise]
        if near:
            dist = sorted(c["distance_pct"] for c in near)
            ratio = sorted(c["time_ratio"] for c in near)
            excess = sorted(c["misfit"] - c["compromise_misfit"] * (1 + ABOVE_COMPROMISE) for c in near)
            routes = defaultdict(list)   # the routes differ in what a run does besides the update
            for v in runs:
                if v.compromise:
                    routes[v.route].append(v.compromise["time_ratio"])
            split = ", ".join(f"{route} {sorted(r)[len(r) // 2]:.3g}x" for route, r in sorted(routes.items()))
            lines.append(f"\n{name}: answer to the judge's least-squares compromise, largest parameter distance "
                         f"median {dist[len(dist) // 2]:.3g} % (max {dist[-1]:.3g} %) of the reference; run time "
                         f"median {ratio[len(ratio) // 2]:.3g}x the compromise's (max {ratio[-1]:.3g}x; median "
                         f"by route: {split}); misfit "
                         f"over the compromise's + {ABOVE_COMPROMISE:.0%} in {sum(above_compromise(c) for c in near)} "
                         f"(largest excess {excess[-1]:.3g}), {len(near)} runs")
    return "\n".join(lines)


def _families() -> dict:
    from acceptance import families as F
    from acceptance import generator as G

    def named(index: int):
        """The named problems of `acceptance.generator` (each a known failure class, fixed data):
        in family; a right answer as for the random problems."""
        return list(G.named_problems().values())[index]()

    def random(seed: int):
        """The random problems of `acceptance.generator` (chains, beams, frames, exported matrices;
        frequencies, shapes and driving-point antiresonances, exact or noisy): in family. A right
        answer: verified, every determined parameter at the truth (or a mirror image), the truth
        inside every reported range."""
        return G.random_problem(seed)

    fams = [Family("random", random, **IN_FAMILY), Family("named", named, **IN_FAMILY)]
    fams += [Family(name, F.MAKERS[name], worse_max=0, above_compromise_max=0)
             for name in ("coarse_mesh", "root_spring", "sensor_masses")]
    fams += [Family("biased_channel", F.biased_channel, first_min=BIASED_FIRST),
             Family("frequency_shift", F.frequency_shift),
             Family("misnumbered_zero", F.misnumbered_zero, first_min=BIASED_FIRST)]
    fams += [Family(name, F.MAKERS[name], **IN_FAMILY)
             for name in ("close_modes", "cross_receptance", "symmetric_ring", "hidden_mode", "mass_normalized",
                          "caughey_damping")]
    fams += [Family(name, F.MAKERS[name], **SIZE) for name in SIZE_FAMILIES]
    fams += [Family("shear_building", F.shear_building, worse_max=0, above_compromise_max=0),
             Family("dashpot_damping", F.dashpot_damping, worse_max=0),
             Family("frf_test", F.frf_test, worse_max=0)]
    return {f.name: f for f in fams}


#: The size families (`acceptance.families.many_dofs`, `many_parameters`).
SIZE_FAMILIES = ("many_dofs", "many_parameters")
#: Every family by name.
FAMILIES = _families()

#: The families drawn beyond the random problems and the named ones.
NEW_FAMILIES = ("coarse_mesh", "root_spring", "sensor_masses", "biased_channel", "frequency_shift", "misnumbered_zero",
                "close_modes",
                "cross_receptance", "symmetric_ring", "hidden_mode", "mass_normalized", "caughey_damping",
                "dashpot_damping", "frf_test", *SIZE_FAMILIES)

#: Seeds of the random family whose failure class the first 31 do not show (found by
#: `benchmarks/acceptance.py` on 2026-11-25 and -26; each is described in `tests/acceptance/test_acceptance.py`).
REGRESSION_SEEDS = (51, 142, 167, 204, 236, 266, 358, 368, 574)

#: The random seeds of the CI profile: one seed per class (structure, problem kind, exact or
#: noisy data) that seeds 0-30 draw, and the regression seeds. Left out of 0-30: 5, 19 and 26,
#: whose class seed 22, 28 and the regression seed 266 already draw. Nine of 0-30 are replaced by
#: a seed of the same class that cost less CPU on both routes when measured (2026-12-06, each
#: verified then): 7 -> 356, 9 -> 396, 10 -> 473, 11 -> 154, 13 -> 223, 24 -> 306, 25 -> 144,
#: 27 -> 199, 30 -> 123 (3.5-7.3 s each before, 0.8-3.6 s after). Seeds 0-119 all run in the
#: ``dev`` profile. The trade is in docs/testing.md.
CI_RANDOM = (*sorted(set(range(31)) - {5, 7, 9, 10, 11, 13, 19, 24, 25, 26, 27, 30}),
             123, 144, 154, 199, 223, 306, 356, 396, 473)

#: Seeds per family of each profile of `benchmarks/acceptance.py`. ``ci``: the test suite's
#: profile (`tests/acceptance/test_acceptance.py`); ``dev``: the development profile; ``full``:
#: the full profile (over 2,000 runs); ``held-out``: seeds never run during development, run only
#: at the end of a change, to compare their rates with the development seeds'.
PROFILES = {
    "ci": {"named": range(9), "random": (*CI_RANDOM, *REGRESSION_SEEDS),
           **{f: range(1) for f in NEW_FAMILIES if f != "many_parameters"}},
    "dev": {"named": range(9), "random": range(120), **{f: range(15) for f in NEW_FAMILIES},
            "shear_building": range(3)},
    "full": {"named": range(9), "random": range(1200), **{f: range(100) for f in NEW_FAMILIES},
             "shear_building": range(20)},
    "held-out": {"random": range(100000, 100400), **{f: range(100000, 100050) for f in NEW_FAMILIES},
                 "shear_building": range(100000, 100010)},
}


def profile_jobs(name: str) -> list[tuple[str, int]]:
    """The ``(family, seed)`` pairs of a profile."""
    return [(family, seed) for family, seeds in PROFILES[name].items() for seed in seeds]
