"""A static equilibrium: the minimum of a potential energy, differentiable in its parameters.

``minimize`` finds the unknowns ``z`` (f[F]) at which ``energy(data,
params, z)`` is least, by Newton's method inside ``jax.jit``: the gradient
by ``jax.grad``, Hessian-vector products by ``jax.jvp`` of it, each Newton
step solved by conjugate gradients (``jax.scipy.sparse.linalg.cg``,
Jacobi-preconditioned by ``diagonal``, an approximation of the Hessian's
diagonal), then a backtracking (Armijo) line search on the energy. It stops
when the largest component of the gradient (a nodal force residual, for a
potential energy in displacements) is below ``tolerance(data, params)``, or
after ``Newton.steps`` steps.

**Derivatives** with respect to ``params`` (any pytree of floats) come from
the implicit-function theorem, not from unrolling the loop: at the minimum
``F(z, θ) = ∇_z Π(z, θ) = 0``, so ``dz/dθ = -H⁻¹ ∂F/∂θ`` with ``H = ∇²_z Π``,
symmetric, and a cotangent ``z̄`` of the solution pulls back to ``θ̄ =
-(∂F/∂θ)ᵀ λ`` with ``H λ = z̄``: one more conjugate-gradient solve, as a
Newton step is (a ``jax.custom_vjp``; reverse mode only). ``data`` (any
pytree of arrays: a mesh, say) is held fixed: it gets no cotangent. Nothing
here knows what the energy describes.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax import Array

__all__ = ["Energy", "Newton", "minimize"]


@dataclasses.dataclass(frozen=True)
class Newton:
    """Newton's method's settings (static: a change compiles anew).

    Attributes:
      steps: at most this many Newton steps.
      cg_tol: CG's tolerance, relative to the step's right-hand side.
      cg_steps: at most this many CG iterations per Newton step (and in the adjoint).
      halvings: at most this many halvings of a step in the line search.
    """

    steps: int = 40
    cg_tol: float = 1e-12
    cg_steps: int = 4_000
    halvings: int = 30


Energy = Callable[[object, object, Array], Array]
"""``energy(data, params, z) -> f[]``: the potential to minimise over ``z`` (f[F])."""


def _newton(energy, diagonal, newton: Newton, data, params, z: Array, tolerance: Array):
    """Minimises the energy from ``z``; returns ``(z, (residual, Newton steps))``."""
    potential = functools.partial(energy, data, params)
    value_and_gradient = jax.value_and_grad(potential)
    gradient = jax.grad(potential)

    def step(state):
        z, value, g, _, count = state
        inverse = 1 / diagonal(data, params, z)
        direction, _ = jax.scipy.sparse.linalg.cg(
            lambda v: jax.jvp(gradient, (z,), (v,))[1],
            -g,
            tol=newton.cg_tol,
            maxiter=newton.cg_steps,
            M=lambda r: inverse * r,
        )
        slope = jnp.vdot(g, direction)

        # Armijo's backtracking: halve the step until the energy falls by a part
        # of what the slope promises. Near the minimum the full step is taken.
        def too_high(search):
            t, tries = search
            return (potential(z + t * direction) > value + 1e-4 * t * slope) & (
                tries < newton.halvings
            )

        t, _ = jax.lax.while_loop(
            too_high, lambda search: (search[0] / 2, search[1] + 1), (jnp.ones_like(value), 0)
        )
        z = z + t * direction
        value, g = value_and_gradient(z)
        return z, value, g, jnp.max(jnp.abs(g)), count + 1

    def going(state):
        *_, residual, count = state
        return (residual > tolerance) & (count < newton.steps)

    value, g = value_and_gradient(z)
    z, _, _, residual, count = jax.lax.while_loop(
        going, step, (z, value, g, jnp.max(jnp.abs(g)), 0)
    )
    return z, (residual, count)


@functools.partial(jax.custom_vjp, nondiff_argnums=(0, 1, 2, 3, 4))
def _minimum(energy, diagonal, start, tolerance, newton, data, params):
    z, (residual, steps) = _newton(
        energy, diagonal, newton, data, params, start(data, params), tolerance(data, params)
    )
    return z, residual, steps


def _minimum_forward(energy, diagonal, start, tolerance, newton, data, params):
    found = _minimum(energy, diagonal, start, tolerance, newton, data, params)
    return found, (data, params, found[0])


def _minimum_backward(energy, diagonal, start, tolerance, newton, saved, cotangents):
    # The adjoint of the module's docstring. Not through custom_root or a
    # custom_jvp: their transpose of jax's cg raises (jax-ml/jax issue 33872,
    # open), so reverse mode only.
    data, params, z = saved
    z_bar = cotangents[0]
    forces = jax.grad(energy, argnums=2)  # F = ∇_z Π(data, params, z)
    inverse = 1 / diagonal(data, params, z)
    adjoint, _ = jax.scipy.sparse.linalg.cg(
        lambda v: jax.jvp(lambda y: forces(data, params, y), (z,), (v,))[1],
        z_bar,
        tol=newton.cg_tol,
        maxiter=newton.cg_steps,
        M=lambda r: inverse * r,
    )
    _, pullback = jax.vjp(lambda prm: forces(data, prm, z), params)
    (params_bar,) = pullback(-adjoint)
    return jax.tree.map(_no_cotangent, data), params_bar


def _no_cotangent(array):
    if jnp.issubdtype(array.dtype, jnp.inexact):
        return jnp.zeros_like(array)
    return np.zeros(array.shape, jax.dtypes.float0)


_minimum.defvjp(_minimum_forward, _minimum_backward)


def minimize(
    energy: Energy,
    diagonal: Energy,
    start: Callable[[object, object], Array],
    tolerance: Callable[[object, object], Array],
    data,
    params,
    newton: Newton = Newton(),
) -> tuple[Array, Array, Array]:
    """The unknowns at the energy's minimum: ``(z, residual, Newton steps)``.

    Args:
      energy: ``energy(data, params, z) -> f[]``, the potential (twice differentiable in
        ``z`` almost everywhere: a piecewise quadratic penalty is fine).
      diagonal: ``diagonal(data, params, z) -> f[F]``, > 0: an approximation of the
        Hessian's diagonal, Jacobi's preconditioner.
      start: ``start(data, params) -> f[F]``, where Newton's method starts.
      tolerance: ``tolerance(data, params) -> f[]``: it stops when the gradient's
        largest component is below this.
      data: held fixed (no cotangent): the mesh, say.
      params: differentiable, by the implicit-function theorem (reverse mode).
      newton: the method's settings (static).

    Returns:
      ``z`` (f[F]), the gradient's largest component at it (``residual``, f[]),
      and the Newton steps taken (i32[]); check the residual against the
      tolerance: at ``newton.steps`` steps the method stops regardless.
    """
    return _minimum(energy, diagonal, start, tolerance, newton, data, params)
