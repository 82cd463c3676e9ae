"""The affine form of a parametric model in normalized parameters, paper Eqs. 12-15 (the form and
its checks: docs/method.md, section 2):

    M(xbar) = M0 + sum_i xbar_i M_i,      K(xbar) = K0 + sum_i xbar_i K_i,      M_i = (dM/dp_i) p_ref,i

the parameter matrices of a builder function by complex step (Eq. 15, `affine_from_builder`),
those of an `Assembly` of linear expressions assembled directly (`affine_from_assembly`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from vibupdate.model.assembly import Assembly, NamedDofs, System
from vibupdate.model.parameters import Parameter, normalized_bounds, to_normalized, to_physical


Builder = Callable[[dict], "System | tuple"]

#: Largest size of the two dense parameter stacks of `AffineModel.dense_stacks` (bytes), so that a
#: small model with very many parameters keeps the sparse path (400 DOFs, 48 parameters: 125 MB).
DENSE_STACK_BYTES = 128 * 2**20

#: Measurement maps an `AffineModel` keeps (`AffineModel.measurement`): more lists of names
#: than a run's measured shapes and checks ask for (one or two per measured mode); all are
#: dropped when a further one would exceed it.
MEASUREMENTS_KEPT = 256


@dataclass(frozen=True)
class AffineModel(NamedDofs):
    """Affine parametric model, Eqs. 12-14.

    Attributes
    ----------
    parameters : tuple of Parameter, length n_x
        The updating parameters, in the order of ``xbar``.
    dofs : tuple of str, length n
        The names of the degrees of freedom (``"y2"``, ``"phi2"``), in the order of the matrices' rows.
    M0, K0 : csr_matrix, shape (n, n)
        Nominal mass and stiffness matrices (SI units).
    M_par, K_par : tuple of csr_matrix, each shape (n, n), length n_x
        Derivatives of ``M`` and ``K`` with respect to the normalized parameters.
    matrix_precision : float, optional
        Relative precision of the matrix entries: each is known to within this fraction of its
        magnitude (5e-10 for a model read from 10 significant digits). None: exact to double
        precision. The rounding unit of the tests that tell a zero eigenvalue from rounding
        (`vibupdate.modal.rigid`) and of the shape ratios' rounding floor
        (`vibupdate.inverse.verify`).
    sensors : tuple of Sensor
        Readings that are linear combinations of DOFs (`vibupdate.model.measurement`): measured
        shapes may be given at their names as well as at DOFs (`measurement`).
    """

    parameters: tuple[Parameter, ...]
    dofs: tuple[str, ...]
    M0: sp.csr_matrix
    K0: sp.csr_matrix
    M_par: tuple[sp.csr_matrix, ...]
    K_par: tuple[sp.csr_matrix, ...]
    matrix_precision: float | None = None
    sensors: tuple = ()

    @property
    def n_dofs(self) -> int:
        """Number of degrees of freedom ``n``, the size of the matrices."""
        return self.M0.shape[0]

    @property
    def n_parameters(self) -> int:
        """Number of updating parameters ``n_x``."""
        return len(self.parameters)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The parameters' names, in the order of ``xbar``."""
        return tuple(p.name for p in self.parameters)

    def measures(self, name: str) -> bool:
        """Whether ``name`` is a DOF or a sensor of the model.

        Parameters
        ----------
        name : str
            A DOF name or a sensor name.

        Returns
        -------
        bool
            True when measured shapes may be given at ``name``.
        """
        return name in self._measured_names

    @cached_property
    def _measured_names(self) -> frozenset:
        return frozenset(self.dofs) | {s.name for s in self.sensors}

    def measurement(self, names) -> sp.csr_matrix:
        """The measurement map of ``names`` (DOFs or sensors).

        A model vector's readings at ``names`` are ``measurement(names) @ phi``
        (`vibupdate.model.measurement.measurement_rows`). It depends on the model and the names
        only: built once per list of names and kept (the most recent `MEASUREMENTS_KEPT`
        lists), the same matrix for every caller, so it is not to be changed in place.

        Parameters
        ----------
        names : sequence of str
            DOF or sensor names (`measures`), in the order of the readings.

        Returns
        -------
        csr_matrix, shape (len(names), n)
            One row per name: a unit row for a DOF, the sensor's combination of DOFs for a
            sensor.
        """
        from vibupdate.model.measurement import measurement_rows

        key = tuple(names)
        kept = self._measurements.get(key)
        if kept is None:
            kept = measurement_rows(self._positions, self.sensors, list(key))
            if len(self._measurements) >= MEASUREMENTS_KEPT:
                self._measurements.clear()
            self._measurements[key] = kept
        return kept

    @cached_property
    def _measurements(self) -> dict:
        return {}

    @cached_property
    def _positions(self) -> dict:
        return {d: i for i, d in enumerate(self.dofs)}

    def normalized(self, values) -> np.ndarray:
        """Normalize physical parameter values (Eq. 12).

        Parameters
        ----------
        values : array_like, shape (n_x,)
            Parameter values, each in its parameter's ``unit``.

        Returns
        -------
        ndarray, shape (n_x,)
            ``xbar = (values - nominal) / reference``, dimensionless.
        """
        return to_normalized(self.parameters, values)

    def physical(self, xbar) -> np.ndarray:
        """Physical parameter values of a normalized point (Eq. 12 inverted).

        Parameters
        ----------
        xbar : array_like, shape (n_x,)
            Normalized parameters.

        Returns
        -------
        ndarray, shape (n_x,)
            ``nominal + reference * xbar``, each in its parameter's ``unit``.
        """
        return to_physical(self.parameters, xbar)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Box of ``xbar`` from the parameter bounds.

        Returns
        -------
        lower, upper : ndarray, shape (n_x,)
            The parameters' ``lower`` and ``upper`` bounds, normalized (a negative reference
            swaps them).
        """
        return normalized_bounds(self.parameters)

    def matrices(self, xbar=None) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Mass and stiffness matrices at a normalized point, Eq. 13.

        Parameters
        ----------
        xbar : array_like, shape (n_x,), optional
            Normalized parameters; None is the nominal model.

        Returns
        -------
        M, K : csr_matrix, shape (n, n)
            ``M0 + sum_i xbar_i M_i`` and ``K0 + sum_i xbar_i K_i`` (SI units).

        Raises
        ------
        ValueError
            ``xbar`` does not have shape (n_x,).
        """
        if xbar is None:
            return self.M0, self.K0
        xbar = self._point(xbar)
        return tuple(self._combine(stacked, xbar) for stacked in self._stacked)

    def _point(self, xbar) -> np.ndarray:
        xbar = np.zeros(self.n_parameters) if xbar is None else np.asarray(xbar, dtype=float)
        if xbar.shape != (self.n_parameters,):
            raise ValueError(f"xbar must have shape ({self.n_parameters},), got {xbar.shape}")
        return xbar

    def solver_matrices(self, xbar=None) -> tuple:
        """``M(xbar)``, ``K(xbar)`` in the form the solvers take.

        On a model within the dense stacks' reach (`dense_stacks`) they are dense read-only
        arrays, one matrix-vector product over the stacks, kept for the last point asked (an
        evaluation asks at one point several times); `matrices` (csr) otherwise.

        Parameters
        ----------
        xbar : array_like, shape (n_x,), optional
            Normalized parameters; None is the nominal model.

        Returns
        -------
        M, K : ndarray or csr_matrix, shape (n, n)
            The matrices of `matrices`, dense and read-only on the dense path.

        Raises
        ------
        ValueError
            ``xbar`` does not have shape (n_x,).
        """
        stacks = self.dense_stacks
        if stacks is None:
            return self.matrices(xbar)
        xbar = self._point(xbar)
        key = xbar.tobytes()
        kept = self._last_point.get("point")
        if kept is not None and kept[0] == key:
            return kept[1]
        n = self.n_dofs
        flat = stacks.reshape(2, 1 + self.n_parameters, n * n)   # a view: the stacks are contiguous
        both = (flat[:, 0] + xbar @ flat[:, 1:]).reshape(2, n, n)
        both.flags.writeable = False
        pair = (both[0], both[1])
        self._last_point["point"] = (key, pair)   # one assignment: a reader sees a whole pair
        return pair

    @cached_property
    def _last_point(self) -> dict:
        return {}

    def __getstate__(self) -> dict:
        """What a pickle carries (a model sent to a Dask worker): the model's fields and small
        caches, not the dense stacks and the last point's matrices, rebuilt where needed."""
        return {k: v for k, v in self.__dict__.items() if k not in ("dense_stacks", "_last_point")}

    @cached_property
    def dense_stacks(self) -> np.ndarray | None:
        """The matrices stacked as one dense read-only array, on a small model.

        Shape (2, 1 + n_x, n, n): ``[0]`` is ``(M0, M_1, ..., M_nx)``, ``[1]`` is
        ``(K0, K_1, ...)``, for a model of at most `vibupdate.modal.eigen.DENSE_LIMIT` DOFs whose
        two stacks fit in `DENSE_STACK_BYTES`; None otherwise (the sparse path; why:
        docs/notes/eigen-solutions.md, "Small models: dense parameter stacks")."""
        from vibupdate.modal.eigen import DENSE_LIMIT

        n = self.n_dofs
        if n > DENSE_LIMIT or 2 * (1 + self.n_parameters) * n * n * 8 > DENSE_STACK_BYTES:
            return None
        S = np.stack([[sp.csr_matrix(A).toarray() for A in (A0, *parts)]
                      for A0, parts in ((self.M0, self.M_par), (self.K0, self.K_par))])
        S.flags.writeable = False
        return S

    def parameter_products(self, v) -> tuple[np.ndarray, np.ndarray]:
        """Products of every parameter matrix with one vector.

        Parameters
        ----------
        v : array_like, shape (n,)
            A vector on the model's DOFs.

        Returns
        -------
        Mv, Kv : ndarray, shape (n, n_x)
            ``[M_1 v, ..., M_nx v]`` and ``[K_1 v, ..., K_nx v]``.
        """
        v = np.asarray(v, dtype=float)
        if self.dense_stacks is not None:
            Mv, Kv = self.dense_stacks[:, 1:] @ v                 # each (n_x, n)
            return np.ascontiguousarray(Mv.T), np.ascontiguousarray(Kv.T)
        return tuple(np.column_stack([A @ v for A in parts]) if parts else np.zeros((v.size, 0))
                     for parts in (self.M_par, self.K_par))

    def parameter_forms(self, L, R) -> tuple[np.ndarray, np.ndarray]:
        """Bilinear forms of every parameter matrix with pairs of vectors.

        These are the derivative products of `vibupdate.modal.sensitivities`.

        Parameters
        ----------
        L, R : array_like, shape (n, k)
            Left and right vectors, paired column by column.

        Returns
        -------
        LMR, LKR : ndarray, shape (k, n_x)
            ``L[:, j]^T M_i R[:, j]`` and ``L[:, j]^T K_i R[:, j]``.
        """
        L, R = np.asarray(L, dtype=float), np.asarray(R, dtype=float)
        if self.dense_stacks is not None:   # both stacks in one product
            LMR, LKR = np.einsum("nk,spnk->skp", L, self.dense_stacks[:, 1:] @ R)
            return LMR, LKR
        return tuple(np.column_stack([np.einsum("ij,ij->j", L, A @ R) for A in parts]) if parts
                     else np.zeros((L.shape[1], 0)) for parts in (self.M_par, self.K_par))

    @staticmethod
    def _combine(stacked, xbar) -> sp.csr_matrix:
        base, per_parameter, indices, indptr, shape = stacked
        return sp.csr_matrix((base + per_parameter @ xbar, indices, indptr), shape=shape)

    @cached_property
    def _stacked(self):
        return _stack_on_union(self.M0, self.M_par), _stack_on_union(self.K0, self.K_par)

    @cached_property
    def fingerprint(self) -> str:
        """A hash of the matrices ``M0``, ``K0``, ``M_i``, ``K_i``.

        Made by `vibupdate.modal.kept.content_key`: two models with the same fingerprint have
        the same ``M(xbar)``, ``K(xbar)`` at every ``xbar`` (and the same `matrix_precision`);
        the key of caches of results computed from them.
        """
        from vibupdate.modal.kept import content_key

        extra = b"" if self.matrix_precision is None else np.float64(self.matrix_precision).tobytes()
        return content_key(self.M0, self.K0, *self.M_par, *self.K_par, extra=extra)

    def matrices_at(self, values) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """Mass and stiffness matrices at physical parameter values.

        Parameters
        ----------
        values : array_like, shape (n_x,)
            Parameter values, each in its parameter's ``unit``.

        Returns
        -------
        M, K : csr_matrix, shape (n, n)
            `matrices` at the normalized point of ``values`` (SI units).
        """
        return self.matrices(self.normalized(values))


@dataclass(frozen=True)
class Lumped:
    """A lumped addition to a model: a mass (``matrix = "M"``) on ``dof``, or a spring
    (``matrix = "K"``) from ``dof`` to ground or to ``other``.

    ``value`` is affine in the physical parameters: it has ``constant`` (float) and
    ``coefficients`` (pairs of parameter name and ``d value / d p``), like
    `vibupdate.model.expressions.LinearExpression`. Units: kg or kg m^2 for a mass, N/m or N m/rad for a
    spring.
    """

    matrix: str
    dof: str
    value: object
    other: str | None = None


def _lumped_matrix(model: "AffineModel", item: Lumped, amount: float) -> sp.csr_matrix:
    i = model.dof(item.dof)
    n = model.n_dofs
    if item.other is None:
        return sp.csr_matrix(([amount], ([i], [i])), shape=(n, n))
    j = model.dof(item.other)
    return sp.csr_matrix(([amount, amount, -amount, -amount], ([i, j, i, j], [i, j, j, i])), shape=(n, n))


def with_lumped(model: "AffineModel", additions: Sequence[Lumped]) -> "AffineModel":
    """``model`` plus lumped masses and springs, with their parameter dependence.

    The nominal matrices gain each value at the nominal parameters; the parameter matrices
    gain ``coefficient * p_ref`` (Eq. 13), so ``M(xbar)``, ``K(xbar)`` are those of the
    assembled model at every ``xbar``. This is the one path by which a configuration's
    additions enter a model of any type (elements, builder or matrices).
    """
    if not additions:
        return model
    known = {p.name: k for k, p in enumerate(model.parameters)}
    nominal = {p.name: p.nominal for p in model.parameters}
    mats = {"M": [model.M0, list(model.M_par)], "K": [model.K0, list(model.K_par)]}
    for item in additions:
        if item.matrix not in mats:
            raise ValueError(f"a lumped addition goes to 'M' or 'K', got {item.matrix!r}")
        for name, _ in item.value.coefficients:
            if name not in known:
                raise ValueError(f"the value of the addition on {item.dof!r} names {name!r}, which is not a parameter")
        target = mats[item.matrix]
        target[0] = target[0] + _lumped_matrix(model, item, float(item.value(nominal)))
        for name, coef in item.value.coefficients:
            k = known[name]
            target[1][k] = target[1][k] + _lumped_matrix(model, item, coef * model.parameters[k].reference)
    return replace(model, M0=sp.csr_matrix(mats["M"][0]), K0=sp.csr_matrix(mats["K"][0]),
                   M_par=tuple(sp.csr_matrix(A) for A in mats["M"][1]),
                   K_par=tuple(sp.csr_matrix(A) for A in mats["K"][1]))


def with_sensors(model: "AffineModel", sensors) -> "AffineModel":
    """``model`` with the readings ``sensors`` (`vibupdate.model.measurement.Sensor`), checked
    against its DOFs (`vibupdate.model.measurement.check_sensors`); the matrices are unchanged."""
    from vibupdate.model.measurement import check_sensors

    return replace(model, sensors=check_sensors(model.dofs, tuple(sensors)))


def restricted(model: "AffineModel", names: Sequence[str]) -> "AffineModel":
    """``model`` with only the parameters ``names`` free, in the model's order; every other
    parameter is held at its nominal value.

    Exact for the affine form: the nominal value is ``xbar = 0``, where a parameter's matrices
    contribute nothing, so holding it there drops its ``M_i``, ``K_i`` and leaves ``M0``,
    ``K0`` as they are.
    """
    known = model.parameter_names
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"{', '.join(map(repr, unknown))} {'is' if len(unknown) == 1 else 'are'} not a parameter "
                         f"of the model ({', '.join(known)})")
    keep = [k for k, n in enumerate(known) if n in set(names)]
    if len(keep) == len(known):
        return model
    return replace(model, parameters=tuple(model.parameters[k] for k in keep),
                   M_par=tuple(model.M_par[k] for k in keep), K_par=tuple(model.K_par[k] for k in keep))


def _stack_on_union(A0, parts):
    """``A0`` and ``parts`` on their union sparsity pattern, so that ``A(xbar)`` is one
    vector operation: the data of ``A0`` on the pattern, shape (nnz,), the parameter
    matrices' data as a sparse matrix of shape (nnz, n_x) (column ``i`` holds ``A_i``; each
    parameter usually touches a small part of the pattern), and the pattern's indices."""
    mats = [sp.coo_matrix(A) for A in (A0, *parts)]
    n_cols = mats[0].shape[1]
    lin = [A.row.astype(np.int64) * n_cols + A.col for A in mats]
    pattern = np.unique(np.concatenate(lin))
    where = [np.searchsorted(pattern, li) for li in lin]
    base = np.bincount(where[0], weights=mats[0].data, minlength=pattern.size)
    counts = [li.size for li in lin[1:]]
    columns = np.repeat(np.arange(len(parts)), counts)
    rows = np.concatenate(where[1:]) if parts else np.zeros(0, dtype=np.int64)
    values = np.concatenate([A.data for A in mats[1:]]) if parts else np.zeros(0)
    per_parameter = sp.csr_matrix((values, (rows, columns)), shape=(pattern.size, len(parts)))
    rows_, cols = np.divmod(pattern, n_cols)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows_, minlength=mats[0].shape[0]))])
    return base, per_parameter, cols.astype(np.int32), indptr.astype(np.int32), mats[0].shape


def _as_system(result, dofs: Sequence[str] | None) -> System:
    """Normalize a builder's return value to a `System` with sparse matrices."""
    if isinstance(result, System):     # a user's System may hold dense arrays
        return System(sp.csr_matrix(result.M), sp.csr_matrix(result.K), tuple(result.dofs))
    if not isinstance(result, tuple) or len(result) not in (2, 3):
        raise ValueError(
            "a model builder must return a System or a tuple (M, K) or (M, K, dofs), "
            f"got {type(result).__name__}"
        )
    M, K = (sp.csr_matrix(m) for m in result[:2])
    names = tuple(result[2]) if len(result) == 3 else dofs
    if names is None:
        names = tuple(f"q{i + 1}" for i in range(M.shape[0]))
    return System(M, K, tuple(names))


def symmetric_error(A: sp.spmatrix) -> float:
    """``max |A - A^T| / max |A|`` (0 for an empty matrix)."""
    scale = abs(A).max() if A.nnz else 0.0
    return float(abs(A - A.T).max() / scale) if scale > 0 else 0.0


def check_matrices(M, K, dofs: Sequence[str], *, what: str = "model", precision: float | None = None) -> None:
    """Raise ValueError unless ``M``, ``K`` are square, equal in size, finite, symmetric and
    physically admissible (`vibupdate.model.physical.definiteness`: ``M`` positive definite or
    semidefinite with massless DOFs held by ``K``, ``K`` positive semidefinite, zero
    eigenvalues told from rounding at the entries' relative ``precision``); ``dofs`` must
    name every row."""
    from vibupdate.model.physical import definiteness

    for name, A in (("mass", M), ("stiffness", K)):
        if A.ndim != 2 or A.shape[0] != A.shape[1]:
            raise ValueError(f"{what}: {name} matrix must be square, got shape {A.shape}")
    if M.shape != K.shape:
        raise ValueError(f"{what}: mass matrix {M.shape} and stiffness matrix {K.shape} differ in size")
    if len(dofs) != M.shape[0]:
        raise ValueError(f"{what}: {len(dofs)} DOF names for matrices of size {M.shape[0]}")
    if len(set(dofs)) != len(dofs):
        raise ValueError(f"{what}: DOF names are not unique")
    for name, A in (("mass", M), ("stiffness", K)):
        if not np.all(np.isfinite(A.data)):
            raise ValueError(f"{what}: {name} matrix has non-finite entries")
        err = symmetric_error(A)
        if err > 1e-9:
            raise ValueError(f"{what}: {name} matrix is not symmetric (relative asymmetry {err:.2e})")
    problem = definiteness(M, K, precision).problem
    if problem:
        raise ValueError(f"{what}: {problem}")


def complex_step_jacobians(builder: Builder, parameters: Sequence[Parameter], dofs=None):
    """Nominal matrices and normalized parameter matrices of a builder by complex step (Eq. 15).

    Returns
    -------
    nominal : System
        The builder's output at the nominal values (real).
    M_par, K_par : list of csr_matrix
        ``dM/dxbar_i = Im(M(p0 + j h e_i)) / h * p_ref,i`` and likewise for ``K``.
    """
    nominal_values = {p.name: p.nominal for p in parameters}
    nominal = _as_system(builder(dict(nominal_values)), dofs)
    if np.iscomplexobj(nominal.M.data) or np.iscomplexobj(nominal.K.data):
        nominal = System(sp.csr_matrix(nominal.M.real), sp.csr_matrix(nominal.K.real), nominal.dofs)
    M_par, K_par = [], []
    for p in parameters:
        h = _complex_step(p)
        out = _as_system(_call_complex(builder, nominal_values, p, h), dofs)
        if out.M.shape != nominal.M.shape or out.K.shape != nominal.K.shape:
            raise ValueError(f"the builder changed the matrix size when parameter '{p.name}' moved")
        M_par.append(sp.csr_matrix(out.M.imag / h * p.reference))
        K_par.append(sp.csr_matrix(out.K.imag / h * p.reference))
    for A in M_par + K_par:
        A.eliminate_zeros()
    return nominal, M_par, K_par


def _complex_step(p: Parameter) -> float:
    """The step ``h`` of Eq. 15 for ``p``: far below rounding of the value, exact derivative."""
    return 1e-20 * abs(p.reference)


def _call_complex(builder: Builder, values: dict, p: Parameter, h: float):
    """The builder at ``values`` with ``p`` moved by ``j h`` (Eq. 15); a builder that refuses a
    complex value (``float()``, ``math.sqrt`` of a parameter) is named as such."""
    values = {n: complex(v) for n, v in values.items()}
    values[p.name] += 1j * h
    try:
        return builder(values)
    except (TypeError, ValueError) as exc:
        raise ValueError(
            f"the builder fails when parameter '{p.name}' is complex ({type(exc).__name__}: {exc}): the derivatives "
            "come from the complex step (Eq. 15), so a builder must be complex-safe: keep the parameter values as they "
            "come (no float(), math.* or abs() on them) and let the matrices take their type") from None


def _drops_complex_step(builder: Builder, model: "AffineModel", p: Parameter, value: float, which: str) -> bool:
    """Whether the builder turns a complex ``p`` into a real ``which`` (``"M"`` or ``"K"``) at
    ``p = value``, a point where that matrix is known to change with ``p``: the imaginary part,
    the complex step of Eq. 15, is lost (a cast to float: a float array assigned into, ``.real``,
    ``np.real``), so the derivative reads 0. Tested away from the nominal value so that a
    matrix stationary in ``p`` there is not mistaken for a cast."""
    values = {q.name: q.nominal for q in model.parameters} | {p.name: value}
    out = _as_system(_call_complex(builder, values, p, _complex_step(p)), model.dofs)
    return not np.any(np.imag((out.M if which == "M" else out.K).data))


def _second_point(p: Parameter) -> float | None:
    """A point inside the bounds away from the nominal, or None for a fixed parameter."""
    if p.upper > p.nominal:
        return p.nominal + 0.5 * (p.upper - p.nominal)
    if p.lower < p.nominal:
        return p.nominal - 0.5 * (p.nominal - p.lower)
    return None


def _moved(parameters) -> dict:
    """Every parameter that is not fixed at its `_second_point`."""
    return {p.name: v for p in parameters if (v := _second_point(p)) is not None}


def _affine_mismatch(builder, model: AffineModel, values: dict) -> tuple[float, str]:
    out = _as_system(builder(dict(values)), model.dofs)
    xbar = model.normalized([values[p.name] for p in model.parameters])
    M_pred, K_pred = model.matrices(xbar)
    worst, which = 0.0, "M"
    for label, A, A_pred, A0 in (("M", out.M, M_pred, model.M0), ("K", out.K, K_pred, model.K0)):
        A = sp.csr_matrix(A.real)
        change = spla.norm(A - A0)
        err = spla.norm(A - A_pred) / (1e-9 * spla.norm(A0) + 1e-6 * change + 1e-300)
        if err > worst:
            worst, which = err, label
    return worst, which


def check_affine(builder: Builder, model: AffineModel) -> None:
    """Raise ValueError when a parameter enters ``M`` or ``K`` non-affinely.

    Each parameter is moved alone to a second point inside its bounds and the builder is
    compared with the affine prediction; then all parameters move together, which catches
    products of parameters.
    """
    nominal = {p.name: p.nominal for p in model.parameters}
    for p in model.parameters:
        value = _second_point(p)
        if value is None:
            continue
        ratio, which = _affine_mismatch(builder, model, {**nominal, p.name: value})
        if ratio > 1.0 and _drops_complex_step(builder, model, p, value, which):
            raise ValueError(
                f"the builder drops the complex step of parameter '{p.name}': a complex {p.name} gives a real "
                f"{which}, yet {which} changes when {p.name} moves to {value:g}. The derivatives come from the "
                "imaginary part (Eq. 15), which a cast to float loses (float(), a float array assigned into, "
                "np.real, .real): build the matrices in the parameters' own type, e.g. "
                "np.zeros((n, n), dtype=np.result_type(*p.values()))")
        if ratio > 1.0:
            raise ValueError(
                f"parameter '{p.name}' enters {which} non-affinely: at {p.name} = {value:g} the "
                f"affine form (Eqs. 12-14) misses the builder's {which} by {ratio * 1e-6:.2e} of the "
                "change. Reparametrize so that M and K are affine in each parameter "
                "(e.g. update E*I rather than a thickness)."
            )
    moved = _moved(model.parameters)
    if len(moved) > 1:
        ratio, which = _affine_mismatch(builder, model, {**nominal, **moved})
        if ratio > 1.0:
            raise ValueError(
                f"parameters enter {which} jointly non-affinely (a product of parameters?): moving "
                f"{', '.join(moved)} together misses the affine form by {ratio * 1e-6:.2e} of the change"
            )


def affine_from_builder(builder: Builder, parameters: Sequence[Parameter], *, dofs=None,
                        check: bool = True) -> AffineModel:
    """Affine form of a builder ``params -> System | (M, K) | (M, K, dofs)``.

    The parameter matrices are the builder's derivatives by complex step (Eq. 15).

    Parameters
    ----------
    builder : callable
        Receives a dict ``{name: value}`` of physical parameter values and returns a `System`,
        ``(M, K)`` or ``(M, K, dofs)`` (SI units). It must be complex-safe (no ``abs``,
        ``float()`` or comparisons on parameter values).
    parameters : sequence of Parameter, length n_x
        The updating parameters, each named as the builder's dict names it.
    dofs : sequence of str, optional
        DOF names in matrix order, when the builder returns ``(M, K)``; ``q1 ... qn`` by
        default.
    check : bool
        Verify the affine form against the builder at points inside the bounds, each
        parameter moved alone and all together.

    Returns
    -------
    AffineModel
        The nominal matrices and the parameter matrices ``M_i``, ``K_i`` (Eqs. 13-14).

    Raises
    ------
    ValueError
        Parameter names repeat, the nominal matrices are not valid (not symmetric, not
        square), or with ``check`` a parameter enters ``M`` or ``K`` non-affinely or the
        builder drops the complex step.
    """
    parameters = tuple(parameters)
    check_parameter_names(parameters)
    model = _checked(parameters, *complex_step_jacobians(builder, parameters, dofs))
    if check:
        check_affine(builder, model)
    return model


def affine_from_assembly(assembly: Assembly, parameters: Sequence[Parameter], *,
                         check: bool = True) -> AffineModel:
    """Affine form of an `Assembly` whose properties and lumped values are `LinearExpression` s
    of the parameters, assembled directly (`Assembly.affine_parts`), without complex step.

    The model is affine by construction; with ``check`` the assembly with every parameter moved
    inside its bounds (`Assembly.system`) must equal the affine prediction.

    Parameters
    ----------
    assembly : Assembly
        Nodes, elements, lumped items and supports; properties numbers or `LinearExpression` s.
    parameters : sequence of Parameter, length n_x
        Must include every parameter the expressions name.
    check : bool
        Run the safety check (one more assembly of every element).
    """
    parameters = tuple(parameters)
    check_parameter_names(parameters)
    model = _checked(parameters, *assembly.affine_parts(parameters))
    moved = _moved(parameters)
    if check and moved:
        values = {**{p.name: p.nominal for p in parameters}, **moved}
        ratio, which = _affine_mismatch(assembly.system, model, values)
        if ratio > 1.0:
            raise ValueError(
                f"the direct affine assembly misses the assembled {which} by {ratio * 1e-6:.2e} of the "
                f"change when {', '.join(moved)} move together; this is an error in vibupdate, please report it"
            )
    return model


def _checked(parameters: tuple, nominal: System, M_par, K_par) -> AffineModel:
    """The affine model of checked nominal matrices (`check_matrices`) and parameter matrices."""
    check_matrices(nominal.M, nominal.K, nominal.dofs, what="nominal model")
    return AffineModel(parameters, nominal.dofs, nominal.M, nominal.K, tuple(M_par), tuple(K_par))


def check_parameter_names(parameters: Sequence[Parameter]) -> None:
    """A ValueError unless there is at least one parameter and their names are unique."""
    names = [p.name for p in parameters]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"parameter names must be unique; repeated: {', '.join(dup)}")
    if not parameters:
        raise ValueError("a model needs at least one updating parameter")
