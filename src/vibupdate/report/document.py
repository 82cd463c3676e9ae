"""The tables and text of a run's results (`RunResult`): the terminal and ``report.md``.

Each table is built once (`tables`) as a `vibupdate.report.table.Table` and rendered as text
(`terminal_text`) or markdown (`markdown_report`), so the two show the same cells. Every
figure goes through `vibupdate.report.numbers.fmt`, so that no value (missing, NaN,
infinite, huge) can stop a table or the report."""

from __future__ import annotations

from vibupdate.data.names import frequency_name, mode_name
from vibupdate.io.outputs import first_of
from vibupdate.io.records import Identifiability, SolverRecord
from vibupdate.io.results import RunResult
from vibupdate.report.suggestion import run_section_markdown
from vibupdate.options import finite
from vibupdate.report.numbers import fmt
from vibupdate.report.ranges_text import ranges_markdown, ranges_table
from vibupdate.report.table import Column, Table, error_pct, markdown, text, with_reference


#: What the lambda = 0 optimum says: the lifted variables absorb every mismatch, so
#: it is ~0 on every example.
LOWER_BOUND_NOTE = "a valid bound of the global minimum, but it certifies nothing unless positive"

#: Groups of the ranking shown in the terminal and the report (every one is in results.json).
RANKED_SHOWN = 5


def _run(results) -> RunResult:
    """A `RunResult`, from itself or from its document (``results.json`` as a dict)."""
    return results if isinstance(results, RunResult) else RunResult.from_document(results)


def _weak(norms: dict) -> list[str]:
    """Parameters whose sensitivity column norm is below 1 % of the largest finite one
    (a norm that is not finite is neither weak nor the largest)."""
    values = [v for v in norms.values() if finite(v)]
    if not values:
        return []
    top = max(values)
    return [n for n, v in norms.items() if finite(v) and v < 1e-2 * top]


def _condition(ident, n_parameters: int) -> str:
    """The condition number of the sensitivity as text: ``inf`` where it is not finite
    (``null`` in ``results.json``) and the rank is below the number of parameters."""
    if ident.condition is None and ident.rank < n_parameters:
        return "inf (rank deficient)"
    return fmt(ident.condition, ".3g", missing="not computed")


def _interval_hz(row: dict) -> str:
    """The measured value's interval, ``"[lo, hi]"`` Hz; ``"-"`` where the data give none."""
    lo, hi = row.get("measured_lower_hz"), row.get("measured_upper_hz")
    return "-" if lo is None or hi is None else f"[{fmt(lo, '.6g')}, {fmt(hi, '.6g')}]"


def frequency_table(run: RunResult) -> Table:
    """Measured / nominal / updated frequencies with their errors, and any reference columns;
    each datum named by `vibupdate.data.names.frequency_name` (the model mode, or the zero and
    its receptance) with its measurement interval."""
    hz, pct = (lambda name: Column(name, "Hz", ".2f")), Column("err %", spec=".2f")
    docs = [r.as_dict() for r in run.frequencies]
    intervals = [_interval_hz(d) for d in docs]
    shown = any(i != "-" for i in intervals)   # the column only where some datum has an interval
    rows = tuple((r.configuration, frequency_name(d), r.measured_hz, *([i] if shown else []), r.nominal_hz,
                  r.error_nominal_pct, r.updated_hz, r.error_updated_pct)
                 for r, d, i in zip(run.frequencies, docs, intervals))
    table = Table("Frequencies", (Column("cfg"), Column("datum"), hz("measured"),
                                  *([Column("interval", "Hz")] if shown else []), hz("nominal"), pct, hz("updated"),
                                  pct), rows,
                  keys=tuple(f"{r.configuration}/{r.kind}/{r.index}" for r in run.frequencies))
    return with_reference(table, run.paper, "frequencies")


def _mode_names(run: RunResult) -> dict:
    """(configuration, model mode) -> the name of that measured mode (`frequency_name`)."""
    docs = (r.as_dict() for r in run.frequencies if r.kind == "natural")
    return {(d["configuration"], d["model_index"]): frequency_name(d) for d in docs}


def modal_mass_table(run: RunResult) -> Table | None:
    """Measured / nominal / updated modal masses of mass-normalized shapes; None without them."""
    if not run.modal_masses:
        return None
    kg, pct = (lambda name: Column(name, "kg", ".4g")), Column("err %", spec=".2f")
    names = _mode_names(run)
    rows = tuple((r.configuration, names.get((r.configuration, r.mode), mode_name(r.mode)), r.dof,
                  r.measured_lower_kg, r.measured_upper_kg, r.nominal_kg, r.error_nominal_pct, r.updated_kg,
                  r.error_updated_pct) for r in run.modal_masses)
    return Table("Modal masses", (Column("cfg"), Column("mode"), Column("at"), kg("measured from"),
                                  kg("to"), kg("nominal"), pct, kg("updated"), pct), rows,
                 keys=tuple(f"{r.configuration}/{r.mode}" for r in run.modal_masses),
                 notes=("The mass of each mode scaled to 1 at the DOF named, 1 / phi^2 of the mass-normalized mode "
                        "there; errors against the middle of the measured interval.",))


def _sensitivity_notes(run: RunResult) -> tuple[str, ...]:
    """What the sensitivity of the measured data says of the parameters (none without it)."""
    ident = run.identifiability
    if not ident:
        return ()
    n, weak = len(run.parameters), _weak(ident.column_norm)
    return ((f"Sensitivity of the measured data (exact derivatives): rank {ident.rank} of {n}, "
             f"condition {_condition(ident, n)}. "
             + (f"Weakly determined by the data (sensitivity below 1 % of the largest): {', '.join(weak)}."
                if weak else "Every parameter moves the measured data."),)
            + tuple(f"Not determined by the data (exact null direction, normalized parameters): {c}"
                    for c in ident.undetermined_combinations))


def parameter_table(run: RunResult) -> Table:
    """Parameters: nominal, bounds, updated, any reference columns, what the sensitivity says."""
    rows = tuple((p.name, p.unit, p.nominal, p.lower, p.upper, p.updated) for p in run.parameters)
    table = Table("Parameters", tuple(Column(n) for n in ("parameter", "unit", "nominal", "lower", "upper", "updated")),
                  rows, keys=tuple(p.name for p in run.parameters), notes=_sensitivity_notes(run))
    return with_reference(table, run.paper, "parameters")


def damping_table(run: RunResult) -> Table | None:
    """Measured / Rayleigh / Caughey damping ratios with their errors, the Caughey law, and
    any reference columns; None without damping data."""
    if not run.damping:
        return None
    pct = Column("err %", spec=".1f")
    names = _mode_names(run)
    rows = tuple((d.configuration, names.get((d.configuration, d.mode), mode_name(d.mode)), d.measured, d.rayleigh,
                  d.error_rayleigh_pct, d.identified, d.error_pct) for d in run.damping)
    info = run.damping_model
    law = info and (f"Caughey exponents Y = [{', '.join(fmt(y, 'g') for y in info.exponents)}], coefficients "
                    f"beta = [{', '.join(fmt(b) for b in info.beta)}]; Rayleigh baseline Y = [0, 1]. "
                    f"Weights: {info.weights_text}.")
    table = Table("Damping ratios", (Column("cfg"), Column("mode"), Column("measured"), Column("Rayleigh"),
                                     pct, Column("Caughey"), pct), rows,
                  keys=tuple(f"{d.configuration}/{d.mode}" for d in run.damping), notes=(law,) if info else ())
    return with_reference(table, run.paper, "damping")


def summary_table(run: RunResult) -> Table:
    """Mean errors and problem size, and any reference columns."""
    s, size = run.summary, run.problem_size
    rows = [("mean_error_nominal_pct", "mean frequency error, nominal", "%", fmt(s.mean_error_nominal_pct, ".2f")),
            ("mean_error_updated_pct", "mean frequency error, updated", "%", fmt(s.mean_error_updated_pct, ".2f"))]
    if s.mean_damping_error_pct is not None:
        rows += [("mean_damping_error_rayleigh_pct", "mean damping error, Rayleigh", "%",
                  fmt(s.mean_damping_error_rayleigh_pct, ".1f")),
                 ("mean_damping_error_pct", "mean damping error, Caughey", "%", fmt(s.mean_damping_error_pct, ".1f"))]
    rows += [(key, label, "", fmt(size[key], "d")) for key, label in (
        ("n_parameters", "parameters"), ("n_mode_unknowns", "mode unknowns"),
        ("n_adjunct_unknowns", "adjunct unknowns"), ("n_lifted", "lifted scalars")) if key in size]
    table = Table("Summary", (Column("quantity"), Column("unit"), Column("this run")),
                  tuple(r[1:] for r in rows), keys=tuple(r[0] for r in rows))
    return with_reference(table, run.paper, "summary")


def checks_table(solver: SolverRecord) -> Table:
    """The verification checks of the answer with their findings."""
    rows = tuple((c.name, "pass" if c.passed else ("FAIL" if c.severity == "error" else "warning"), c.message)
                 for c in solver.checks)
    return Table("Verification", (Column("check"), Column("result"), Column("finding")), rows)


def steps_table(solver: SolverRecord) -> Table:
    """Every solve of the homotopy."""
    rows = tuple((st.lam, st.objective, st.iterations, st.status.value, "yes" if st.cold else "no", st.seconds)
                 for st in solver.steps)
    return Table("Solves", (Column("lambda", spec=".4f"), Column("objective", spec=".4e"),
                            Column("iterations", spec="d"), Column("status"), Column("cold"),
                            Column("seconds", spec=".3f")), rows)


def declared_sensors_table(run: RunResult) -> Table | None:
    """The sensors the case declared (``docs/sensors.md``), each with the combination of DOFs
    it reads; None without them."""
    if not run.declared_sensors:
        return None

    def reading(weights: dict[str, float]) -> str:
        terms = [f"{'-' if w < 0 else '+'} {abs(w):.6g} {d}" for d, w in weights.items()]
        text = " ".join(terms)
        return text[2:] if text.startswith("+ ") else "-" + text[2:]

    rows = tuple((s.sensor, reading(s.weights)) for s in run.declared_sensors)
    return Table("Sensors", (Column("sensor"), Column("reads (weight x DOF)")), rows)


def sensors_table(run: RunResult) -> Table | None:
    """Where the measured points sit on an imported FE mesh; None without sensors."""
    if not run.sensors:
        return None
    from vibupdate.model.fe.oblique import direction_text

    rows = tuple((s.sensor, s.dof, "+" if s.sign > 0 else "-", direction_text(s.direction), s.distance_m)
                 for s in run.sensors)
    return Table("Measured points on the mesh", (Column("sensor"), Column("DOF"), Column("sign"),
                                                 Column("reads along (x, y, z)"), Column("distance", "m", ".3g")),
                 rows)


def trials_table(run: RunResult) -> Table | None:
    """The groups of data whose removal fits best, ranked, with the fit without each (objective,
    frequency errors on the data kept, shape misses, the screened checks); None without a
    diagnosis."""
    d = run.diagnosis
    if d is None:
        return None
    title = (f"Which data conflict (the answer failed {', '.join(d.failed)}; {d.groups} groups of the data, each "
             f"left out in turn; {fmt(d.seconds, '.1f')} s)\nfull data: objective {fmt(d.objective, '.3g')}, "
             f"frequency error mean {fmt(d.mean_error_pct, '.3g')} % max {fmt(d.max_error_pct, '.3g')} %")
    more = len(d.trials) - RANKED_SHOWN
    notes = ((f"The other {more} groups fit worse without them (all in `results.json`, `diagnosis.trials`).",)
             if more > 0 else ())
    rows = tuple((str(rank), t.label, fmt(t.share, ".2f"), fmt(t.objective, ".3g"), fmt(t.mean_error_pct, ".3g"),
                  fmt(t.max_error_pct, ".3g"), fmt(t.shape_misses, "d"),
                  "pass" if t.passed else "fail: " + ", ".join(t.failed))
                 for rank, t in enumerate(d.trials[:RANKED_SHOWN], start=1))
    return Table(title, tuple(Column(n) for n in ("rank", "left out", "share of the misfit", "objective",
                                                  "freq. err. mean %", "freq. err. max %", "shape misses",
                                                  "checks")), rows, notes=notes)


def best_table(run: RunResult) -> Table | None:
    """The parameters updated with all the data beside those without the top group; None
    without that update."""
    best = run.diagnosis.best if run.diagnosis is not None else None
    if best is None:
        return None
    full = {p.name: p.updated for p in run.parameters}
    units = {p.name: p.unit for p in run.parameters}
    rows = tuple((n, units.get(n, ""), full.get(n), v, fmt(error_pct(v, full.get(n)), ".3g"))
                 for n, v in best.values.items())
    return Table(f"updated again without the {best.without_label}: {best.status.value}",
                 (Column("parameter"), Column("unit"), Column("all data (not verified)", spec=".5g"),
                  Column("without the group", spec=".5g"), Column("differ %")), rows)


def tables(results) -> dict[str, Table]:
    """Every table of a run, by name (those that do not apply left out), in report order."""
    run = _run(results)
    solver = run.solver
    built = {"summary": summary_table(run), "checks": checks_table(solver) if solver.checks else None,
             "trials": trials_table(run), "best": best_table(run), "parameters": parameter_table(run),
             "ranges": ranges_table(run.identifiability, [p.name for p in run.parameters]),
             "frequencies": frequency_table(run), "modal_masses": modal_mass_table(run), "sensors": sensors_table(run),
             "declared_sensors": declared_sensors_table(run), "damping": damping_table(run),
             "steps": steps_table(solver)}
    return {name: t for name, t in built.items() if t is not None}


#: The tables the terminal shows, in its order.
TERMINAL = ("frequencies", "modal_masses", "parameters", "ranges", "damping", "summary", "trials", "best")


def terminal_text(results) -> str:
    """The tables printed after a run, and the solver's status and warnings."""
    run = _run(results)
    shown = tables(run)
    solver = run.solver
    blocks = []
    for name in (n for n in TERMINAL if n in shown):
        blocks.append(text(shown[name]))
        if name == "summary":
            blocks.append("\n".join(
                [f"solver: {solver.status.value}" + (f", verdict {solver.verdict.value}" if solver.verdict else "")
                 + f", objective {fmt(solver.objective, '.4e')}, relaxation "
                 f"lower bound {fmt(solver.relaxation_lower_bound, '.4e')} ({LOWER_BOUND_NOTE}), "
                 f"{len(solver.steps)} solves, {fmt(solver.seconds, '.2f')} s"]
                + [f"warning: {w}" for w in solver.warnings]))
    return "\n\n".join(blocks)


def verification_markdown(solver: SolverRecord) -> list[str]:
    """The verification section: what each stage did and every check with its figures."""
    out = ["## Verification", ""]
    if not solver.checks:
        return out + ["The updated model was not checked: the homotopy did not reach lambda = 1.", ""]
    pol = solver.polish
    stages = "The first stage (homotopy) gave an answer"
    if pol:
        stages += (f"; the polish (bounded least squares of the declared modes' relative frequency errors and the "
                   f"shape-interval penalties) took its objective from {fmt(pol.cost_start, '.4e')} to "
                   f"{fmt(pol.cost, '.4e')} in {pol.evaluations} evaluations of the full model"
                   + (f" ({pol.rounds} rounds on a reduced model, {pol.reduced_evaluations} evaluations "
                      "there; each round checked on the full model)" if pol.rounds else "")
                   + " and was " + ("kept" if pol.kept else "not kept")
                   + (f" (stopped on its {pol.stopped_on} limit: {pol.message})"
                      if pol.stopped_on in ("evaluations", "time") else ""))
    attempts = solver.attempts
    if len(attempts) > 1:
        stages += (f"; the vector boxes were widened {len(attempts) - 1} time(s) because the relaxation proved that "
                   "they excluded every fit (lower bounds "
                   + ", ".join(fmt(a.relaxation_lower_bound, ".3g") for a in attempts) + ")")
    verdict = ("**verified**: every check of the returned model against the data passed" + limited_text(solver.checks)
               if solver.verified else "**not verified**: the failed checks below say why")
    return out + [stages + ". The answer is " + verdict + ".", ""] + markdown(checks_table(solver))


def limited_text(checks) -> str:
    """What limited a verified answer, from the checks' ``limited_by`` (`CheckRow` or
    `vibupdate.inverse.verify.Check`): ``""`` when no check says, else the clause the report
    and the terminal add to the verdict."""
    limits = [c.limited_by for c in checks if c.limited_by]
    if not limits:
        return ""
    if "model_form" in limits:
        names = ", ".join(c.name for c in checks if c.limited_by == "model_form")
        return (f"; within the model-form tolerances only: some data lie outside their measurement intervals "
                f"(check {names}): the model's form limits the fit, or a closer fit exists that the search's starts "
                "did not reach")
    return "; the measurements limit it: every datum lies in its measurement interval"


def diagnosis_markdown(results) -> list[str]:
    """The report's section "Which data conflict"; empty without a diagnosis."""
    run = _run(results)
    d = run.diagnosis
    if d is None:
        return []
    out = ["## Which data conflict", "",
           f"The answer failed {', '.join(d.failed)}: the model does not fit all the data. Each group "
           "of the data (each natural frequency with its shape, each antiresonance, each mode's shape, each shape "
           "DOF across all modes: a biased sensor or driving point corrupts that DOF in every mode) was left out "
           "in turn, the rest refitted from the answer (polish, the same options) and verified on the data kept "
           f"(the consistency check aside). {len(d.trials)} of {d.groups} groups screened"
           + (f", {d.untried} left untried on the limits ({first_of(d.untried_groups, 8, '; ')})"
              if d.untried and d.untried_groups else f", {d.untried} left untried on the limits" if d.untried else "")
           + f", {fmt(d.seconds, '.1f')} s in all. With all the data: objective {fmt(d.objective, '.3g')}, "
           f"frequency error mean {fmt(d.mean_error_pct, '.3g')} %, max {fmt(d.max_error_pct, '.3g')} %. "
           "Ranked by the fit without the group (passing first, then the objective):", ""]
    out += markdown(trials_table(run))
    best = d.best
    if best:
        failed = [c.name for c in best.checks if c.severity == "error" and not c.passed]
        out += [f"Updated again in full (the same options) without the {best.without_label}: **{best.status.value}**"
                + (f" (failed {', '.join(failed)})" if failed else ", every check passed on the data kept")
                + f"; frequency error on the data kept mean {fmt(best.mean_error_pct, '.3g')} %, max "
                f"{fmt(best.max_error_pct, '.3g')} %; {fmt(best.seconds, '.2f')} s.", ""] + markdown(best_table(run))
    return out


def matrix_files_markdown(results) -> list[str]:
    """One line naming the matrix files, when a model written is not verified."""
    run = _run(results)
    names = [f for per in run.matrix_files.values() for f in per.values()]
    if run.success or not names:
        return []
    return ["Matrices written: " + ", ".join(f"`{n}`" for n in names) + ". The run's model is not verified, and its "
            "files say so (`not_verified_`); `without_worst_` files hold the model updated without the group of "
            "data that conflicts most (prefixed `not_verified_` too when that one is not verified either).", ""]


def _identifiability_markdown(ident: Identifiability | None, units: dict) -> list[str]:
    """The minimum change, the other answers that fit as well, and why ranges are missing."""
    if ident is None:
        return []
    out = ["Minimum change: " + ident.minimum_change + ".", ""] if ident.minimum_change else []
    others = ident.alternatives
    if others:
        out += [f"Not unique: {len(others)} other answer(s) fit the data about as well and pass every check; "
                "the data do not single out the parameters in which they differ:", ""]
        out += [f"- from the {a.start} (objective {fmt(a.objective, '.3g')}): "
                + ", ".join(f"{n} = {fmt(a.values[n], '.5g')} {units.get(n, '')}".rstrip() for n in a.differs)
                for a in others] + [""]
    return out + ([ident.ranges_note + ".", ""] if ident.ranges_note else [])


def sought_text(sought) -> str:
    """The report's line on the search (`vibupdate.inverse.search.Sought`): the starts tried and
    whether uniqueness was searched, with its reason (said once where the reason says it)."""
    said = sought.reason if sought.reason.startswith("uniqueness") else (
        "uniqueness " + ("searched" if sought.uniqueness else "not searched") + f" ({sought.reason})")
    return f"Starts tried: {len(sought.starts)}; {said}."


def markdown_report(results, images: list[tuple[str, str]] = (), notes: list[str] = ()) -> str:
    """``report.md``: summary, verification, diagnosis, parameters, frequencies, damping and
    solver tables, plots, notes."""
    run = _run(results)
    shown, solver = tables(run), run.solver
    section = (lambda title, name: [f"## {title}", ""] + markdown(shown[name]) if name in shown else [])
    out = [f"# vibupdate report: {run.case}", "", f"Status: **{solver.status.value}**"
           + (f", verdict **{solver.verdict.value}**" if solver.verdict else "") + ".", ""]
    if solver.sought:
        sought = solver.sought
        out += [sought_text(sought), ""]
    out += markdown(shown["summary"]) + verification_markdown(solver) + matrix_files_markdown(run)
    out += diagnosis_markdown(run) + run_section_markdown(run.suggestion)
    out += section("Parameters", "parameters")
    out += (markdown(shown["ranges"]) if "ranges" in shown else []) + ranges_markdown(run.identifiability)
    out += _identifiability_markdown(run.identifiability, {p.name: p.unit for p in run.parameters})
    out += section("Frequencies", "frequencies") + section("Modal masses", "modal_masses")
    if "sensors" in shown:
        out += ["## Measured points on the mesh", "",
                "Each sensor reads one DOF of the model: its node's translation projected on the direction "
                "shown. A DOF node:x, node:y or node:z is the translation along that axis; an oblique DOF "
                "node:n1 (n2, n3) is the translation along an oblique sensor's direction, made a DOF by the "
                "import. A sensor pointing against its DOF's direction reads it with sign -; distance from "
                "the sensor's given position to the node.",
                ""] + markdown(shown["sensors"])
    if "declared_sensors" in shown:
        out += ["## Sensors", "", "The sensors the case declares: each reads the weighted sum of the model's DOFs "
                "shown (units of the reading per unit of the DOF). Shapes given at a sensor were compared with the "
                "model through these weights.", ""] + markdown(shown["declared_sensors"])
    out += section("Damping", "damping")
    out += ["## Solver", "", f"{solver.message}; objective {fmt(solver.objective, '.4e')}, "
            f"lower bound of the global minimum from the lambda = 0 relaxation "
            f"{fmt(solver.relaxation_lower_bound, '.4e')} ({LOWER_BOUND_NOTE}: the lifted variables can "
            f"absorb every mismatch); {fmt(solver.seconds, '.2f')} s.", ""] + markdown(shown["steps"])
    if notes:
        out += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    if images:
        out += ["## Plots", ""] + [f"![{title}]({name})" for title, name in images] + [""]
    return "\n".join(out)


def failed_report(case, status, reason: str, notes=()) -> str:
    """The short ``report.md`` written when the full report could not be: what failed and
    where the figures are. Plain text of its arguments only, so that it cannot fail itself."""
    lines = [f"# vibupdate report: {case}", "", f"Status: **{status}**.", "",
             f"The full report could not be written ({reason}). Every figure of the run is in `results.json` "
             "(and the updated matrices in the `.mtx` files); `vibupdate.io.results.load_results` reads it.", ""]
    if notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)
