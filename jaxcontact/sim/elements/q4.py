"""Large-deformation plane-strain quadrilaterals (Q4) with B-bar, for explicit runs.

Bilinear quadrilaterals, updated Lagrangian, 2x2 Gauss points, in units of
mm, N, tonne, s.

* **Kinematics** (Hughes and Winget, 1980, *Int. J. Numer. Meth. Eng.* 15,
  1862-1867): over a step from ``x_n`` to ``x_{n+1}`` the displacement
  increment's gradient is taken on the midpoint configuration,
  ``L = d(du)/dx_{n+1/2}``; its symmetric part is the strain increment handed
  to the material, its skew part ``W`` the spin, and the stress of the step's
  start is rotated by ``R = (I - W/2)^-1 (I + W/2)`` first. The update is
  incrementally objective: a rigid rotation of any size, taken in steps,
  rotates the stress and strains nothing.
* **No volumetric locking** (the reason for quadrilaterals: linear triangles
  lock in isochoric plastic flow): the volumetric part of the strain
  increment at every Gauss point is replaced by the element's mean
  (the B-bar / mean-dilatation method: Nagtegaal, Parks and Rice, 1974;
  Hughes, 1980, *Int. J. Numer. Meth. Eng.* 15, 1413-1418). The deviatoric
  part keeps all four points, so there are no hourglass modes to control.
* **Internal forces** ``f_a = -sum_g sigma_g . grad N_a(x_{n+1}) J_g w_g``
  with the Cauchy stress on the current configuration, per unit thickness
  (plane strain): forces in N per mm of width.
* **Masses** lumped: a quarter of each element's mass to each of its nodes.

The material is any ``materials.Material``: ``step_material`` hands it each
point's strain increment.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

from jaxcontact.sim import materials

__all__ = [
    "CORNERS",
    "DSHAPE",
    "GAUSS",
    "Quads",
    "bulk_viscosity",
    "distortion",
    "grid_mesh",
    "internal_forces",
    "rotate",
    "step_material",
    "strain_and_spin",
]

_G = 1 / np.sqrt(3.0)
GAUSS = np.array([[-_G, -_G], [_G, -_G], [_G, _G], [-_G, _G]])  # weights 1 each
CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


def _shape_derivatives() -> np.ndarray:
    """f64[4 points, 4 nodes, 2]: dN_a/d(xi, eta) of the bilinear shape functions."""
    xi, eta = GAUSS[:, 0][:, None], GAUSS[:, 1][:, None]
    dxi = 0.25 * CORNERS[None, :, 0] * (1 + CORNERS[None, :, 1] * eta)
    deta = 0.25 * CORNERS[None, :, 1] * (1 + CORNERS[None, :, 0] * xi)
    return np.stack([dxi, deta], axis=-1)


DSHAPE = _shape_derivatives()


class Quads(NamedTuple):
    """A quadrilateral mesh: E elements over N nodes, counter-clockwise."""

    nodes: Array  # f[N, 2]  reference coordinates (mm)
    quads: Array  # i32[E, 4]  node indices, counter-clockwise
    mass: Array  # f[N]  lumped nodal masses (t, per mm of thickness)


def grid_mesh(width: float, height: float, nx: int, ny: int, density: float, dtype=jnp.float32):
    """A ``width x height`` (mm) rectangle from the origin, ``nx x ny`` elements.

    Node ``j * (nx + 1) + i`` sits at ``(i * width / nx, j * height / ny)``;
    ``density`` (t/mm³) gives the lumped masses: pass
    ``materials.inertial_density(material)`` for a mass-scaled material.
    """
    x, y = np.meshgrid(np.linspace(0, width, nx + 1), np.linspace(0, height, ny + 1))
    nodes = np.stack([x.ravel(), y.ravel()], -1)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    first = (j * (nx + 1) + i).ravel()
    quads = np.stack([first, first + 1, first + nx + 2, first + nx + 1], -1).astype(np.int32)
    area = (width / nx) * (height / ny)
    mass = np.zeros(len(nodes))
    np.add.at(mass, quads.ravel(), density * area / 4)
    return Quads(jnp.asarray(nodes, dtype), jnp.asarray(quads), jnp.asarray(mass, dtype))


def _gradients(x_elements: Array) -> tuple[Array, Array]:
    """``(dN/dx f[E, 4 points, 4 nodes, 2], det J f[E, 4 points])`` on ``x_elements`` f[E, 4, 2]."""
    dshape = jnp.asarray(DSHAPE, x_elements.dtype)
    jacobian = jnp.einsum("pad,ear->epdr", dshape, x_elements)  # dx_r/dxi_d
    det = jacobian[..., 0, 0] * jacobian[..., 1, 1] - jacobian[..., 0, 1] * jacobian[..., 1, 0]
    inverse = (
        jnp.stack(
            [
                jnp.stack([jacobian[..., 1, 1], -jacobian[..., 0, 1]], -1),
                jnp.stack([-jacobian[..., 1, 0], jacobian[..., 0, 0]], -1),
            ],
            -2,
        )
        / det[..., None, None]
    )  # dxi_d/dx_r, as [r, d]
    return jnp.einsum("pad,eprd->epar", dshape, inverse), det


def _corners(quads: Quads, x: Array, alive: Array | None) -> Array:
    """f[E, 4, 2]: each element's corners on ``x``; an eroded element's
    (``alive`` False) on the reference mesh, so that its (unused) kinematics
    stay finite however tangled its nodes are."""
    corners = x[quads.quads]
    if alive is None:
        return corners
    return jnp.where(alive[:, None, None], corners, quads.nodes[quads.quads])


def distortion(quads: Quads, x: Array) -> Array:
    """f[E]: the smallest ratio over an element's Gauss points of ``det J`` on
    ``x`` to ``det J`` on the reference mesh (1 undeformed in area; 0 or below:
    the element is folded)."""
    _, now = _gradients(x[quads.quads])
    _, then = _gradients(quads.nodes[quads.quads])
    return jnp.min(now / then, axis=1)


def strain_and_spin(
    quads: Quads, x_old: Array, x_new: Array, alive: Array | None = None
) -> tuple[Array, Array]:
    """The strain increment (``d eps_xx, d eps_yy, d eps_zz, d gamma_xy``, f[E, 4, 4])
    with the B-bar mean volumetric part, and the spin increment ``W_xy`` (f[E, 4]).

    B-bar: ``eps = dev(eps) + (theta / 3) I`` in 3D, ``theta`` the element's
    mean volumetric increment; the point's own volume change is replaced,
    which gives ``eps_zz = (theta - tr eps) / 3``, not 0, at a point."""
    old, new = _corners(quads, x_old, alive), _corners(quads, x_new, alive)
    grad, det = _gradients(0.5 * (old + new))
    du = new - old
    gradient = jnp.einsum("epar,eai->epir", grad, du)  # d(du_i)/dx_r
    exx, eyy = gradient[..., 0, 0], gradient[..., 1, 1]
    gamma = gradient[..., 0, 1] + gradient[..., 1, 0]
    spin = 0.5 * (gradient[..., 0, 1] - gradient[..., 1, 0])
    # Mean dilatation: every point takes the element's volume-weighted mean.
    volume = exx + eyy
    mean = jnp.sum(volume * det, axis=1, keepdims=True) / jnp.sum(det, axis=1, keepdims=True)
    shift = (mean - volume) / 3
    return jnp.stack([exx + shift, eyy + shift, shift, gamma], axis=-1), spin


def rotate(stress: Array, spin: Array) -> Array:
    """(xx, yy, zz, xy) stresses turned by the Hughes–Winget rotation of spin ``W_xy``.

    In 2D, ``R = (I - W/2)^-1 (I + W/2)`` is a rotation by ``theta`` with
    ``tan(theta / 2) = W_xy / 2`` (``W`` has ``W_xy = -W_yx``), so the stress
    turns by ``sigma' = R sigma R^T``; ``sigma_zz`` is unchanged.
    """
    half = spin / 2
    cos = (1 - half**2) / (1 + half**2)
    sin = 2 * half / (1 + half**2)  # R = [[cos, sin], [-sin, cos]]
    sxx, syy, szz, sxy = stress[..., 0], stress[..., 1], stress[..., 2], stress[..., 3]
    c2, s2, cs = cos**2, sin**2, cos * sin
    return jnp.stack(
        [
            c2 * sxx + 2 * cs * sxy + s2 * syy,
            s2 * sxx - 2 * cs * sxy + c2 * syy,
            szz,
            -cs * sxx + (c2 - s2) * sxy + cs * syy,
        ],
        axis=-1,
    )


def bulk_viscosity(quads: Quads, x: Array, v: Array, density, wave_speed, linear, quadratic):
    """f[E]: the artificial bulk viscosity pressure ``q`` (MPa) of each element
    under the velocities ``v`` (von Neumann and Richtmyer, 1950; in the form of
    LS-DYNA's theory manual, section 18):
    ``q = rho l (quadratic l d^2 - linear c d)`` where the volumetric rate
    ``d = div v < 0`` (compression), 0 otherwise, ``l`` the element's size
    (square root of its area) and ``c`` the wave speed. It damps the ringing
    of shocks and contacts over a few elements; it is added to the pressure of
    the internal forces only, never to the material's state."""
    grad, det = _gradients(x[quads.quads])
    rate = jnp.einsum("epar,ear->ep", grad, v[quads.quads])  # div v at each point
    area = jnp.sum(det, axis=1)  # the weights are 1
    rate = jnp.sum(rate * det, axis=1) / area
    size = jnp.sqrt(jnp.abs(area))
    squeeze = jnp.minimum(rate, 0)
    return density * size * (quadratic * size * squeeze**2 - linear * wave_speed * squeeze)


def internal_forces(
    quads: Quads, x: Array, stress: Array, alive: Array | None = None, pressure=None
) -> Array:
    """f[N, 2]: the nodal forces of the Cauchy ``stress`` (f[E, 4, 4]) on
    configuration ``x``; none from elements not ``alive`` (bool[E], eroded);
    ``pressure`` (f[E]) is added to each element's pressure (bulk viscosity)."""
    grad, det = _gradients(_corners(quads, x, alive))
    if pressure is not None:
        volumetric = jnp.asarray([[[1.0, 1.0, 1.0, 0.0]]], stress.dtype)
        stress = stress - pressure[:, None, None] * volumetric
    if alive is not None:
        stress = jnp.where(alive[:, None, None], stress, 0)
    sxx, syy, sxy = stress[..., 0], stress[..., 1], stress[..., 3]
    tensor = jnp.stack([jnp.stack([sxx, sxy], -1), jnp.stack([sxy, syy], -1)], -2)
    element = -jnp.einsum("epij,epaj,ep->eai", tensor, grad, det)
    return jnp.zeros_like(x).at[quads.quads].add(element)


def step_material(
    material: materials.Material,
    quads: Quads,
    state: materials.PointState,
    x_old: Array,
    x_new: Array,
    dt,
    alive: Array | None = None,
) -> tuple[materials.PointState, Array]:
    """The points' state after the motion ``x_old -> x_new`` in ``dt``: stress
    rotated, then updated by the material; and the step's plastic strain
    increment. Eroded elements (``alive`` False) keep their state."""
    strain, spin = strain_and_spin(quads, x_old, x_new, alive)
    turned = state._replace(stress=rotate(state.stress, spin))
    new, plastic = material.update(turned, strain, dt)
    if alive is None:
        return new, plastic
    keep = alive[:, None]
    new = jax.tree.map(
        lambda after, before: jnp.where(
            keep.reshape(keep.shape + (1,) * (after.ndim - 2)), after, before
        ),
        new,
        state,
    )
    return new, jnp.where(keep, plastic, 0)
