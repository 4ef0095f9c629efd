"""A rigid cylinder pressed into an elastic block, against Hertz's line contact.

Plane strain, units mm, N, MPa; forces per mm of thickness. A rigid cylinder
of radius R is pressed with a force P (N/mm) into a linear elastic block
(E, ν) and the block's static equilibrium is found; the contact pressure is
set against Hertz's solution for two cylinders in line contact, here one of
them rigid and the other a half-space (Johnson, *Contact Mechanics*, 1985,
ch. 4, §4.3, eq. 4.43-4.45):

    E* = E / (1 - ν²)              (the rigid cylinder adds no compliance)
    a  = sqrt(4 P R / (π E*))      (the contact half-width)
    p(x) = p0 sqrt(1 - x²/a²),  p0 = 2 P / (π a) = sqrt(P E* / (π R))

so ``dp0/dR = -p0 / (2R)`` and ``dp0/dE = p0 / (2E)``.

**The block** is ``[-W/2, W/2] x [-D, 0]`` with W = 20 a and D = 10 a (a:
Hertz's, for the nominal problem), its bottom fixed and its sides free:
traction-free, as the half-space's surface is. Neither free sides nor rollers
are the half-space (its stresses fall only as 1/r in plane strain: some 0.1
p0 at 10 a); rollers (u_x = 0) change a and p0 by less than 0.1 % at every
mesh here and the approach d by 2 %, so the choice is the simpler one. Its
mesh is a tensor-product grid, uniform with spacing h = 2a / ``across`` over
``|x| <= 1.5 a`` and ``y >= -1.5 a`` and growing geometrically beyond (each
step ``growth`` times the last, at most), each cell cut into two linear
triangles along the same diagonal.

**The contact goes through jaxcontact.** The block's top-surface nodes are
the slaves; the cylinder's lower arc over ``|x| <= 3 a`` is the master, a
polyline of segments half an element long (their sag below the arc,
``s²/8R``, is some 1e-4 of the gap ``a²/2R`` at the contact's edge). The gap
comes from ``jaxcontact.all_to_all``, flat normals, frictionless, and the
pressure from a penalty: the energy ``½ κ Σ_i L_i min(0, g_i)²`` with ``L_i``
node ``i``'s tributary length along the top (half its two edges) and ``κ =
penalty · E* / h`` (N/mm³: a pressure per unit penetration), so node ``i``'s
pressure is ``p_i = κ max(0, -g_i)`` and its force ``L_i p_i``. With the
default ``penalty = 100`` a node sinks ``p / κ`` into the cylinder, at most
``p0 h / (100 E*)``: ``(p0 / E*) / (50 across)`` of ``a``.

**Equilibrium** is the minimum of the total potential energy over the free
displacements ``u`` and the cylinder's downward displacement ``d`` (load
control: ``d`` is an unknown and ``P`` does the work ``P d``):

    Π(u, d) = ½ uᵀ K u + ½ κ Σ_i L_i min(0, g_i(u, d))² - P d,

found by ``jaxcontact.sim.static.minimize``: Newton's method inside
``jax.jit``, the gradient by ``jax.grad``, Hessian-vector products by
``jax.jvp`` of it, each step solved by conjugate gradients
(``jax.scipy.sparse.linalg.cg``, Jacobi-preconditioned, relative tolerance
``Solver.cg_tol``), then a backtracking (Armijo) line
search on Π. The penalty is piecewise quadratic, so once the set of pressed
nodes settles Newton's step is exact to CG's tolerance; it stops when the
largest nodal force residual is below ``Solver.tol`` P.

**Derivatives** with respect to the problem's parameters (R, P, E, ν) come
from the implicit-function theorem, not from unrolling the loop: at the
minimum ``∇Π(z, θ) = 0``, so a cotangent of the solution ``z`` is pulled
back through one more CG solve with the same Hessian (a ``jax.custom_vjp``;
reverse mode only). The mesh is held fixed, built for the nominal problem.
While the set of pressed nodes does not change the discrete problem is
linear in P and E and the polyline's height at a node linear in R, so the
FE peak pressure is piecewise linear in them: ``jax.grad`` gives the slope
of the piece, which equals a central difference of the FE value and
approaches Hertz's derivative as the mesh is refined (the benchmark,
benchmarks/simulations.py, measures how fast).

What the model leaves out: small strain and linear elasticity (the block's
stresses are far above any yield stress of steel; Hertz's theory is linear
elastic too; ``setup`` refuses a problem with a > R/10, a strain p0/E* =
a/2R above 5 %); friction (Hertz's contact is frictionless); the half-space (a
finite block: in plane strain the half-space's displacement grows like log
r, so the approach ``d`` depends on the block's size and is not compared;
``a`` and ``p(x)`` are local and hardly do); the penalty's penetration; and
the gap is measured from the nodes' displaced positions, as a contact search
does, where Hertz's linear theory takes the undeformed ones.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact import Surface, all_to_all
from jaxcontact.problems.hertz.config import (
    FINE,
    MOST_WIDTH,
    NOMINAL,
    SEGMENTS_PER_ELEMENT,
    SPAN,
    Indentation,
    _check,
)
from jaxcontact.problems.hertz.theory import Hertz, hertz
from jaxcontact.sim import static
from jaxcontact.sim.elements.triangle import Mesh, strain_energy, triangle_mesh
from jaxcontact.sim.materials import Elastic

__all__ = [
    "Block",
    "Equilibrium",
    "Result",
    "Solver",
    "equilibrium",
    "fit_half_width",
    "peak_pressure",
    "run",
    "setup",
]


class Block(NamedTuple):
    """The block's mesh and its top surface (a pytree of arrays; T top nodes, M segments)."""

    mesh: Mesh  # N nodes, E triangles; mesh.free False on the fixed bottom
    free_dofs: Array  # i32[F]  the unknown displacement components, 2 node + component
    top: Array  # i32[T]  the top surface's nodes by increasing x: the slaves
    tributary: Array  # f[T]  each top node's share of the surface (mm)
    centre: Array  # i32[]  the top node at x = 0 (its index in ``top``)
    angles: Array  # f[M + 1]  the cylinder arc's nodes, radians from its lowest point
    element: Array  # f[]  h, the element size at the contact (mm)


def _graded(element: float, inner: float, outer: float, growth: float) -> np.ndarray:
    """f64: 0 = s_0 < s_1 < ... = ``outer``: steps of ``element`` to about ``inner``,
    then steps growing by ``growth``, the grown ones scaled to end at ``outer``."""
    fine = max(1, round(inner / element))
    steps, reach, step = [element] * fine, fine * element, element
    grown = []
    while reach + sum(grown) < outer * (1 - 1e-9):
        step *= growth
        grown.append(step)
    if grown:
        grown = list(np.asarray(grown) * (outer - reach) / sum(grown))
    else:  # the uniform zone reached the edge
        steps = list(np.full(fine, outer / fine))
    return np.concatenate([[0.0], np.cumsum(steps + grown)])


def setup(
    problem: Indentation = NOMINAL,
    across: int = 12,
    *,
    width: float = 20.0,
    depth: float = 10.0,
    growth: float = 1.25,
    dtype=None,
) -> Block:
    """The block's mesh for ``problem`` (host; sized by Hertz's a of ``problem``).

    Args:
      problem: sizes the mesh: a = Hertz's half-width.
      across: elements across the contact width 2a (h = 2a / across), >= 2.
      width: the block's width W in units of a, > 2 SPAN.
      depth: its depth D in units of a, > FINE.
      growth: the largest ratio of neighbouring element sizes outside the
        uniform zone, in (1, 2].
      dtype: float64 by default (``equilibrium`` needs it), float32 with x64 off.

    Nodes are numbered row by row from the bottom (x inner); the top row is
    the slaves, ``top``. The bottom row is fixed (``mesh.free``), the sides
    free. The mesh is symmetric about x = 0 but for its diagonals.

    Example:
      >>> found = setup(Indentation(), 12)
      >>> found.mesh.nodes.shape, found.mesh.triangles.shape, found.top.shape
      ((861, 2), (1600, 3), (41,))
      >>> round(float(found.element) / hertz(Indentation()).half_width, 4)  # h / a = 2 / 12
      0.1667
    """
    _check(problem)
    if not (isinstance(across, int | np.integer) and across >= 2):
        raise ValueError(f"across must be an integer >= 2; got {across!r}")
    if not (np.isfinite(width) and width > 2 * SPAN):
        raise ValueError(f"width must be a finite number > {2 * SPAN:g} (units of a); got {width}")
    if not (np.isfinite(depth) and depth > FINE):
        raise ValueError(f"depth must be a finite number > {FINE:g} (units of a); got {depth}")
    if not (1 < growth <= 2):
        raise ValueError(f"growth must be in (1, 2]; got {growth}")
    a = hertz(problem).half_width
    # Hertz's theory and this model's small strain both ask a << R: the strain
    # p0 / E* is a / 2R, and the master arc covers |x| <= SPAN a of the cylinder.
    if a > MOST_WIDTH * problem.radius:
        raise ValueError(
            f"problem must give Hertz's a / R at most {MOST_WIDTH:g} (a strain p0 / E* = a / 2R "
            f"of {MOST_WIDTH / 2:.0%} at most); got a / R = {a / problem.radius:.3g}: less "
            "force, or a larger radius or modulus"
        )
    dtype = dtype or (jnp.float64 if jax.config.jax_enable_x64 else jnp.float32)
    h = 2 * a / across
    half = _graded(h, FINE * a, width * a / 2, growth)
    xs = np.concatenate([-half[:0:-1], half])
    ys = -_graded(h, FINE * a, depth * a, growth)[::-1]
    nx, ny = len(xs), len(ys)
    nodes = np.stack(np.meshgrid(xs, ys, indexing="xy"), axis=-1).reshape(-1, 2)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="xy")
    c00 = (j * nx + i).ravel()
    c10, c01, c11 = c00 + 1, c00 + nx, c00 + nx + 1
    # One diagonal direction throughout, so that every top node lies in three
    # triangles alike. Diagonals mirrored about x = 0 (a symmetric mesh) leave
    # the node at x = 0 in two or four, unlike its neighbours, and its
    # pressure, the peak, several per cent off theirs.
    triangles = np.concatenate([np.stack([c00, c10, c11], -1), np.stack([c00, c11, c01], -1)])
    rows = np.arange(ny)[:, None] * nx + np.arange(nx)[None, :]
    boundary = np.concatenate([rows[1:, 0], rows[-1, 1:], rows[-2:0:-1, -1]])
    free = nodes[:, 1] > -depth * a * (1 - 1e-12)
    mesh = triangle_mesh(nodes, triangles, free, boundary, Elastic(), dtype=dtype)
    top = rows[-1]
    edges = np.diff(xs)
    tributary = (np.concatenate([[0.0], edges]) + np.concatenate([edges, [0.0]])) / 2
    free_dofs = np.flatnonzero(np.repeat(free, 2))
    count = SEGMENTS_PER_ELEMENT * math.ceil(2 * SPAN * a / h)
    count += 1 - count % 2  # odd: the middle segment, not a vertex, lies under x = 0
    reach = math.asin(min(1.0, SPAN * a / problem.radius))
    return Block(
        mesh,
        jnp.asarray(free_dofs, np.int32),
        jnp.asarray(top, np.int32),
        jnp.asarray(tributary, dtype),
        jnp.asarray(int(np.argmin(np.abs(xs))), np.int32),
        jnp.asarray(np.linspace(-reach, reach, count + 1), dtype),
        jnp.asarray(h, dtype),
    )


@dataclasses.dataclass(frozen=True)
class Solver:
    """The solver's settings (static: a change compiles anew).

    Attributes:
      penalty: κ in units of E* / h (N/mm³). At 100 a node sinks some 1e-4 h
        and the penalty's own error in the pressure is below the mesh's (at 10
        the L2 error at 12 elements across was 1.4 times larger).
      tol: Newton stops when the largest nodal force residual is below tol P.
      newton_steps: at most this many Newton steps.
      cg_tol: CG's tolerance, relative to the step's right-hand side.
      cg_steps: at most this many CG iterations per Newton step.
      halvings: at most this many halvings of a step in the line search.
      radius: the contact search radius in units of h: it must exceed every
        penetration (a node deeper is not found, and its penalty lost).
    """

    penalty: float = 100.0
    tol: float = 1e-10
    newton_steps: int = 40
    cg_tol: float = 1e-12
    cg_steps: int = 4_000
    halvings: int = 30
    radius: float = 4.0

    def __post_init__(self):
        for name in ("penalty", "tol", "cg_tol", "radius"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"Solver.{name} must be a finite number > 0; got {value!r}")
        for name in ("newton_steps", "cg_steps", "halvings"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"Solver.{name} must be an integer >= 1; got {value!r}")

    @property
    def newton(self) -> static.Newton:
        """The Newton-CG settings (``jaxcontact.sim.static``)."""
        return static.Newton(self.newton_steps, self.cg_tol, self.cg_steps, self.halvings)


class Equilibrium(NamedTuple):
    """The solution of one solve (arrays; T top nodes)."""

    displacement: Array  # f[N, 2]  the block's nodal displacements (mm)
    approach: Array  # f[]  d, the cylinder's downward displacement (mm)
    gap: Array  # f[T]  the top nodes' gaps to the cylinder, 0 where not found (mm)
    normal: Array  # f[T, 2]  the cylinder's outward normal at each top node's closest point
    pressure: Array  # f[T]  κ max(0, -gap) (MPa)
    residual: Array  # f[]  the largest nodal force residual at the end (N/mm)
    newton_steps: Array  # i32[]


def _cylinder(block: Block, radius, approach) -> Surface:
    """The cylinder's lower arc, its lowest point at (0, -approach), counter-clockwise
    (left to right along the bottom): its normals point down, out of the cylinder."""
    theta = block.angles
    # 2R sin²(θ/2) for R (1 - cos θ): no cancellation near the lowest point.
    height = 2 * radius * jnp.sin(theta / 2) ** 2
    nodes = jnp.stack([radius * jnp.sin(theta), height - approach], -1)
    count = theta.shape[0] - 1
    segments = jnp.stack([jnp.arange(count), jnp.arange(1, count + 1)], -1)
    return Surface(nodes, segments)


def _unpack(block: Block, z: Array) -> tuple[Array, Array]:
    """The nodal displacements f[N, 2] and the approach d of the unknowns ``z`` f[F + 1]."""
    count = block.mesh.nodes.shape[0]
    u = jnp.zeros(2 * count, z.dtype).at[block.free_dofs].set(z[:-1]).reshape(count, 2)
    return u, z[-1]


def _moduli(problem: Indentation) -> tuple[Elastic, Array]:
    material = Elastic(young=problem.young, poisson=problem.poisson)
    return material, problem.young / (1 - problem.poisson**2)


def _contact(block: Block, problem: Indentation, solver: Solver, z: Array):
    u, d = _unpack(block, z)
    x = block.mesh.nodes[block.top] + u[block.top]
    surface = _cylinder(block, problem.radius, d)
    contact = all_to_all(x, surface, radius=solver.radius * block.element)
    return jnp.where(contact.found, contact.gap, 0), contact


def _energy(block: Block, problem: Indentation, solver: Solver, z: Array) -> Array:
    """Π(u, d): strain energy + penalty energy - P d (N mm per mm of thickness)."""
    material, modulus = _moduli(problem)
    u, d = _unpack(block, z)
    gap, _ = _contact(block, problem, solver, z)
    kappa = solver.penalty * modulus / block.element
    pressed = jnp.minimum(gap, 0)
    penalty = kappa / 2 * jnp.sum(block.tributary * pressed**2)
    return strain_energy(block.mesh, u, material) + penalty - problem.force * d


def _diagonal(block: Block, problem: Indentation, solver: Solver, z: Array) -> Array:
    """f[F + 1]: an approximation of the Hessian's diagonal, for Jacobi's preconditioner:
    the stiffness's own diagonal ``Σ_e A_e ((λ + 2μ) g_ai² + μ g_aj²)`` and the active
    nodes' penalty springs ``κ L_i n_i²``, and ``Σ κ L_i n_y²`` for d."""
    material, modulus = _moduli(problem)
    lam, mu = material.lame
    mesh = block.mesh
    squares = mesh.area[:, None, None] * mesh.gradients**2  # (E, 3, 2)
    sums = jnp.zeros_like(mesh.nodes).at[mesh.triangles].add(squares)
    elastic = (lam + 2 * mu) * sums + mu * sums[:, ::-1]
    gap, contact = _contact(block, problem, solver, z)
    kappa = solver.penalty * modulus / block.element
    springs = jnp.where(gap < 0, kappa * block.tributary, 0)[:, None] * contact.normal**2
    nodal = elastic.at[block.top].add(springs).reshape(-1)[block.free_dofs]
    along_d = jnp.maximum(jnp.sum(springs[:, 1]), kappa * block.element)
    return jnp.concatenate([nodal, along_d[None]])


def _start(block: Block, problem: Indentation) -> Array:
    """f[F + 1]: the Newton start: the block at rest, the cylinder sunk to half Hertz's
    width (d = (a/2)² / 2R), so that a few nodes press on it."""
    modulus = problem.young / (1 - problem.poisson**2)
    quarter = problem.force * problem.radius / (math.pi * modulus)  # (a/2)²
    start = jnp.zeros(block.free_dofs.shape[0] + 1, block.mesh.nodes.dtype)
    return start.at[-1].set(quarter / (2 * problem.radius))


def _equilibrium(block: Block, problem: Indentation, solver: Solver):
    """``(z, residual, Newton steps)`` at Π's minimum (``static.minimize``): its gradient
    with respect to ``problem`` by the implicit-function theorem, the mesh held fixed.
    Newton stops when the largest nodal force residual is below ``solver.tol`` P."""
    return static.minimize(
        lambda block, problem, z: _energy(block, problem, solver, z),
        lambda block, problem, z: _diagonal(block, problem, solver, z),
        _start,
        lambda block, problem: solver.tol * problem.force,
        block,
        problem,
        solver.newton,
    )


@functools.partial(jax.jit, static_argnames="solver")
def equilibrium(block: Block, problem: Indentation, solver: Solver = Solver()) -> Equilibrium:
    """The block's static equilibrium under the cylinder (one compiled program).

    Args:
      block: the mesh (``setup``), fixed; it need not be the one ``problem`` sizes.
      problem: R, P, E, ν (traced: differentiable, by the implicit-function theorem).
      solver: the solver's settings (static).

    Returns:
      An ``Equilibrium``; check ``residual`` against ``solver.tol * P`` (``run`` does).
    """
    _needs_x64()
    z, residual, steps = _equilibrium(block, problem, solver)
    u, approach = _unpack(block, z)
    gap, contact = _contact(block, problem, solver, z)
    _, modulus = _moduli(problem)
    kappa = solver.penalty * modulus / block.element
    pressure = kappa * jnp.maximum(-gap, 0)
    return Equilibrium(u, approach, gap, contact.normal, pressure, residual, steps)


def peak_pressure(block: Block, problem: Indentation, solver: Solver = Solver()) -> Array:
    """f[]: the FE pressure of the node at x = 0, the peak (MPa).

    A function of the solution, differentiable in ``problem`` (reverse mode):
    piecewise linear in R, P and E while the set of pressed nodes stays the
    same (the module's docstring says why). For example (it compiles for some
    seconds, so it is not run as a doctest)::

        grads = jax.grad(peak_pressure, argnums=1)(setup(), Indentation())
        grads.radius, grads.young  # dp0/dR (MPa/mm), dp0/dE (MPa/MPa)
    """
    return equilibrium(block, problem, solver).pressure[block.centre]


class Result(NamedTuple):
    """``run``'s answer, host numbers (T top nodes). Errors are fractions: FE / Hertz - 1."""

    problem: Indentation  # what was solved
    x: np.ndarray  # f64[T]  the top nodes' x (reference, mm), increasing
    pressure: np.ndarray  # f64[T]  their FE pressures (MPa)
    exact: Hertz  # Hertz's a, p0, E* for the problem
    half_width: float  # FE a (mm): where the least-squares fit p² = c (a² - x²) vanishes
    peak: float  # FE p0 (MPa): the pressure of the node at x = 0
    half_width_error: float  # FE a / Hertz's - 1
    peak_error: float  # FE p0 / Hertz's - 1
    l2_error: float  # sqrt(Σ L_i (p_i - p(x_i))² / Σ L_i p(x_i)²) over the top nodes
    across: int  # elements across Hertz's contact width 2a
    element: float  # h, the element size at the contact (mm)
    active: int  # top nodes pressing on the cylinder (p > 0)
    penetration: float  # the deepest node's penetration into the cylinder (mm)
    approach: float  # d, the cylinder's downward displacement (mm; depends on the block)
    force: float  # Σ L_i p_i n_y: the contact's force on the cylinder (N/mm), = P
    nodes: int  # the block's nodes
    residual: float  # the largest nodal force residual (N/mm)
    newton_steps: int


def fit_half_width(x, pressure) -> tuple[float, float]:
    """``(a, p0)`` of the least-squares fit ``p² = p0² (1 - x²/a²)`` over the nodes with
    ``p > 0``: Hertz's form, which ``p²``, linear in ``x²``, makes a linear fit (mm, MPa).

    The FE contact ends between a pressed node and a free one, h apart: the fit
    places its end within the element, from every pressed node.

    Example:
      >>> x = np.linspace(-1.2, 1.2, 13)
      >>> [round(value, 6) for value in fit_half_width(x, 3 * np.sqrt(np.clip(1 - x**2, 0, 1)))]
      [1.0, 3.0]
    """
    x, pressure = np.asarray(x, np.float64), np.asarray(pressure, np.float64)
    pressed = pressure > 0
    if pressed.sum() < 2:
        raise ValueError(f"pressure must be > 0 at two nodes or more; got {int(pressed.sum())}")
    design = np.stack([np.ones(pressed.sum()), -(x[pressed] ** 2)], axis=1)
    (squared_peak, slope), *_ = np.linalg.lstsq(design, pressure[pressed] ** 2, rcond=None)
    return math.sqrt(squared_peak / slope), math.sqrt(squared_peak)


def _needs_x64() -> None:
    if not jax.config.jax_enable_x64:
        raise ValueError(
            "jaxcontact.problems.hertz needs float64: the penetration is some 1e-5 of the "
            "contact's width; jax.config.update('jax_enable_x64', True) first"
        )


def run(
    problem: Indentation = NOMINAL,
    across: int = 12,
    *,
    solver: Solver = Solver(),
    width: float = 20.0,
    depth: float = 10.0,
) -> Result:
    """Presses the cylinder into the block, solves for equilibrium and compares with Hertz.

    Args:
      problem: R (mm), P (N/mm), E (MPa), ν.
      across: elements across Hertz's contact width 2a (the mesh; h = 2a / across).
      solver: the penalty and the solver's tolerances.
      width: the block's width in units of Hertz's a.
      depth: the block's depth in units of Hertz's a.

    Returns:
      A ``Result``: the nodal pressures, the FE a and p0 and their errors against Hertz.

    Raises:
      ValueError: on a bad argument, or with x64 off (float64 is needed).
      RuntimeError: when Newton's method did not reach ``solver.tol``.
    """
    _needs_x64()
    if not isinstance(solver, Solver):
        raise ValueError(f"solver must be a Solver; got {type(solver).__name__}")
    mesh = setup(problem, across, width=width, depth=depth)
    exact = hertz(problem)
    found = jax.tree.map(np.asarray, equilibrium(mesh, problem, solver))
    if not found.residual <= solver.tol * problem.force:
        raise RuntimeError(
            f"Newton's method stopped after {int(found.newton_steps)} steps with a force "
            f"residual of {float(found.residual):.3g} N/mm, above {solver.tol:g} P"
        )
    top = np.asarray(mesh.top)
    x = np.asarray(mesh.mesh.nodes, np.float64)[top, 0]
    tributary = np.asarray(mesh.tributary, np.float64)
    pressure = found.pressure.astype(np.float64)
    half_width, _ = fit_half_width(x, pressure)
    peak = float(pressure[int(mesh.centre)])
    expected = exact.pressure(x)
    l2 = math.sqrt(np.sum(tributary * (pressure - expected) ** 2) / np.sum(tributary * expected**2))
    return Result(
        problem=problem,
        x=x,
        pressure=pressure,
        exact=exact,
        half_width=half_width,
        peak=peak,
        half_width_error=half_width / exact.half_width - 1,
        peak_error=peak / exact.peak - 1,
        l2_error=l2,
        across=across,
        element=float(mesh.element),
        active=int((pressure > 0).sum()),
        penetration=float(max(0.0, -found.gap.min())),
        approach=float(found.approach),
        force=float(-np.sum(tributary * pressure * found.normal[:, 1])),
        nodes=int(mesh.mesh.nodes.shape[0]),
        residual=float(found.residual),
        newton_steps=int(found.newton_steps),
    )
