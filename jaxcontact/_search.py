"""The search object: sizes allocated once on the host, one jitted search per step.

jax-md's neighbour lists split the work in two: ``allocate`` looks at
concrete data on the host and fixes the buffer sizes; ``update`` runs under
``jit`` with those sizes and says when they were outgrown. ``Search`` does the
same for contact, and adds what a contact search needs: candidates found
within ``radius + skin`` are reused while the slaves and the master together
have moved less than the skin, and found again inside the step (a ``cond``)
when they have not; the overflow flag is carried in the state, so one check
after a ``lax.scan`` covers every step.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import operator
import warnings
from collections.abc import Mapping

import jax
import jax.numpy as jnp
import numpy as np

from jaxcontact import _normals, _removed, _track, _validate
from jaxcontact._pipeline import candidates as _candidates
from jaxcontact._pipeline import driver
from jaxcontact._pipeline import inputs as _inputs
from jaxcontact._pipeline import pairs as _pairs
from jaxcontact._pipeline import segments as _segments
from jaxcontact._pipeline import sizes as _sizes
from jaxcontact._pipeline.pairs import Pairs
from jaxcontact._pipeline.placement import replicated, searched_whole
from jaxcontact._pipeline.sizes import fitted, measure, measure_batch
from jaxcontact._query.closest import CLOSEST
from jaxcontact._query.swept import SWEPT
from jaxcontact._track import Slip
from jaxcontact._types import (
    CELLS_ABOVE,
    CHUNK_ROWS,
    Array,
    Contact,
    ContactList,
    Crossing,
    CrossingList,
    QuerySizes,
    Sizes,
    Surface,
)

METHODS = ("auto", "binned", "unbinned", "exhaustive")


@functools.partial(
    jax.tree_util.register_dataclass,
    data_fields=[
        "candidates",
        "overflow",
        "rebuilds",
        "last_rebuild",
        "lost",
        "last_active",
        "history",
        "slip",
    ],
    meta_fields=["sizes", "reach"],
)
@dataclasses.dataclass(frozen=True)
class SearchState:
    """What a ``Search`` carries from step to step: a pytree with static sizes.

    The sizes are static fields (part of the pytree's structure): a state
    with other sizes compiles the search anew, once per distinct sizes, as a
    new shape would. Everything else is traced.

    Attributes:
      sizes: the capacities of each query the state was allocated for, by
        the query's name: ``state.sizes["closest"]`` (a search with a radius,
        not the exhaustive method) and ``state.sizes["swept"]`` (allocated
        with ``x_prev``). A read-only, hashable mapping (``QuerySizes``).
      candidates: what lies within ``radius + skin``, found at ``allocate``
        or since, with the positions it was found at (``None`` without a
        skin, or on empty inputs: then every step searches afresh).
      overflow: bool[] some search since ``allocate`` outgrew the sizes: a
        contact or crossing may have been missed. It stays True.
      rebuilds: i32[] how often the candidates were found again since
        ``allocate``.
      last_rebuild: i32[] why they were last found again, as bits
        (``rebuild_reasons`` names them): 1 the slaves and the master moved
        more than the skin, 2 a slave row became real, 4 a segment outside
        the pool became real, 8 a real segment was joined to other nodes;
        0 before the first rebuild.
      lost: i32[] how many contacts were lost since ``allocate``: a slave
        active at one ``closest`` step that the next finds nowhere, lying
        behind the segment it touched (within that segment's span), deeper
        than the radius can see. A penetrating slave lies ``|gap|`` from its
        segment, so a penetration deeper than the radius in one step (a fast
        impact) loses the contact, and the body passes through; raise the
        radius (``check_overflow`` raises, saying so). It only grows.
      last_active: i32[N] the segment each slave was active on at the last
        ``closest`` step, -1 where none (``None`` for a search of paths
        only): what ``lost`` is measured against.
      reach: ``radius + skin`` of the search that allocated it (static):
        a search that reaches farther refuses the state.
      history: last step's contact of every slave (the N-row form, for the
        compact form too) for ``Search(track=True)``; ``None`` otherwise.
      slip: the ``Slip`` of every slave over the last ``closest`` step (zeros
        before the first) for ``Search(track=True)``; ``None`` otherwise.
    """

    sizes: QuerySizes
    candidates: _candidates.Candidates | None
    overflow: Array
    rebuilds: Array
    last_rebuild: Array
    lost: Array
    last_active: Array | None = None
    reach: float | None = None
    history: _track.History | None = None
    slip: Slip | None = None

    def forget(self, rows) -> SearchState:
        """This state with the slip history of ``rows`` (bool[N]) forgotten.

        After a remesh, a node renumbering or a body taken out of contact by
        hand: the next step treats those slaves as touching for the first
        time (``persisted`` False, zero slip). Runs under ``jit``.
        """
        if self.history is None:
            raise ValueError("state has no slip history: allocate it with Search(track=True)")
        return dataclasses.replace(self, history=_track.forget(self.history, rows))

    def rebuild_reasons(self) -> list[str]:
        """Why the candidates were last found again, in words (host side; [] if never)."""
        bits = int(np.bitwise_or.reduce(np.asarray(self.last_rebuild).reshape(-1), initial=0))
        return [words for bit, words in _candidates.REBUILD_REASONS.items() if bits & bit]


@dataclasses.dataclass(frozen=True)
class Search:
    """A contact search for the steps of a simulation. Frozen and hashable:
    pass it to ``jit`` as a static argument, or close over it.

    Example:
      >>> import jax
      >>> import jaxcontact
      >>> from jaxcontact.scenes import cutting_scene
      >>> scene = cutting_scene(2_000, 18.0, x_tip_prev=18.2)
      >>> search = jaxcontact.Search(radius=0.1, skin=0.05, method="binned")
      >>> state = search.allocate(scene.x, scene.surface, x_prev=scene.x_prev)
      >>> step = jax.jit(search.closest)
      >>> contact, state = step(state, scene.x, scene.surface)
      >>> bool(contact.overflow), int(contact.found.sum())
      (False, 13)
      >>> moved = scene.x.at[:, 0].add(0.03)  # less than the skin: candidates reused
      >>> contact, state = step(state, moved, scene.surface)
      >>> bool(state.overflow), int(state.rebuilds)
      (False, 0)
      >>> dense = jaxcontact.all_to_all(moved, scene.surface, radius=0.1)
      >>> bool((contact.segment == dense.segment).all())
      True
      >>> contact, state = step(state, scene.x.at[:, 0].add(0.06), scene.surface)
      >>> int(state.rebuilds)  # more than the skin since they were found: found again
      1
      >>> crossing, state = search.swept(state, scene.x_prev, scene.x, scene.surface)
      >>> dense = jaxcontact.swept(scene.x_prev, scene.x, scene.surface)
      >>> int(crossing.crossed.sum()) == int(dense.crossed.sum()) > 0
      True

    Attributes:
      radius: the closest-point search radius (``closest``); ``None`` for a
        search of paths only. A penetrating slave lies ``-gap`` from its
        segment, so the radius must exceed the deepest penetration expected
        in one step: a slave that goes deeper is found nowhere, and its
        contact is lost (``SearchState.lost``). ``allocate`` refuses 0, which
        finds no penetration at all.
      skin: ``0`` (the default) keeps no candidates: every ``closest`` runs
        the whole bucket sort with the allocated sizes. Above 0, candidates
        are found within ``radius + skin`` and reused until the largest
        slave move plus the largest move of a real segment's end since
        exceeds it (or a row or segment becomes real, or a segment is joined
        to other nodes). Reuse skips the broad phase (and the binning) but
        reads every row to check the rule, carries the candidates in the
        state, and searches the longer lists of the wider reach; a step that
        finds them again costs more than one without a skin. Whether it pays
        depends on the scene: commit 5928bf7f76cc:benchmarks/archive/search_step.py
        (one step) and benchmarks/simulations.py (a ``lax.scan``) measure it.
      method: ``"binned"``: bucket sort with the segments binned in cells,
        each kept slave against its cell's segments; ``"unbinned"``: bucket
        sort with each kept slave against every segment; ``"auto"``: binned above
        ``cells_above`` segments, unbinned at or below;
        ``"exhaustive"``: every slave against every segment (``all_to_all``,
        ``swept``), with no sizes and no overflow.
      slack: every measured capacity is multiplied by this at ``allocate``;
        larger sizes last longer as the scene changes, and cost memory and
        time per step.
      block_size: slaves culled together (consecutive rows).
      cells_above: the segment count above which ``"auto"`` bins in cells.
      chunk_rows: kept slaves searched together, fullest cells first.
      compact: ``closest`` returns the found contacts only, as a
        ``ContactList`` whose capacity ``allocate`` measures (the contacts
        found then, and any slave at the radius to within rounding, times
        ``slack``), instead of a ``Contact`` of N rows.
        Faster where few slaves touch (the N rows are never written), and
        what a force assembly by ``segment_sum`` over the contacts wants.
        Likewise ``swept`` returns the crossed paths only, as a
        ``CrossingList`` whose capacity ``allocate(..., x_prev=)`` measures
        (the paths crossing then times ``slack``). Not for the
        ``"exhaustive"`` method.
      track: carry each slave's contact from step to step in the state;
        after each ``closest``, ``state.slip`` is the ``Slip`` of every
        slave since the last step (the repository's docs/contract.md,
        "Slip history").
      normals: ``None``, each segment's own normal, or ``Smooth(corner)``:
        normals interpolated along each segment between nodal normals,
        continuous across a vertex where the outline turns by less than
        ``corner`` degrees (``all_to_all``'s ``normals``).

    A radius per slave: ``radius`` is the static bound the sizes are built
    for; ``closest(..., radius=r)`` takes a traced scalar or f[N] at or
    under it (a new value compiles nothing), and a real slave whose radius
    exceeds it sets ``overflow``.
    """

    radius: float | None = None
    skin: float = 0.0
    method: str = "auto"
    slack: float = 1.5
    block_size: int = 64
    cells_above: int = CELLS_ABOVE
    chunk_rows: int = CHUNK_ROWS
    compact: bool = False
    track: bool = False
    normals: _normals.Smooth | None = None

    def __post_init__(self):
        # Plain Python numbers: the search is hashed as a static argument.
        def number(name, value, kind):
            try:
                return kind(value) if kind is float else operator.index(value)
            except TypeError:
                raise ValueError(f"{name} must be a real {kind.__name__}; got {value!r}") from None

        kinds = {"skin": float, "slack": float, "block_size": int, "cells_above": int}
        for name, kind in {**kinds, "chunk_rows": int}.items():
            object.__setattr__(self, name, number(name, getattr(self, name), kind))
        if self.radius is not None:
            object.__setattr__(self, "radius", number("radius", self.radius, float))
            if not (math.isfinite(self.radius) and self.radius >= 0):
                raise ValueError(f"radius must be finite and >= 0, or None; got {self.radius}")
        if not (math.isfinite(self.skin) and self.skin >= 0):
            raise ValueError(f"skin must be finite and >= 0; got {self.skin}")
        removed = _removed.REMOVED.get(f'jaxcontact.Search(method="{self.method}")')
        if removed is not None:
            old = f'Search(method="{self.method}")'
            raise ValueError(_removed.message(old, removed[0], removed[2]))
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}; got {self.method!r}")
        if not (math.isfinite(self.slack) and self.slack >= 1):
            raise ValueError(f"slack must be finite and >= 1; got {self.slack}")
        for name in ("block_size", "chunk_rows"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be an int >= 1; got {getattr(self, name)!r}")
        if self.cells_above < 0:
            raise ValueError(f"cells_above must be an int >= 0; got {self.cells_above}")
        _normals.check_normals(self.normals)
        for name in ("compact", "track"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"{name} must be a bool; got {getattr(self, name)!r}")
        if self.compact and self.method == "exhaustive":
            raise ValueError(
                'compact=True needs a bucket method ("auto", "binned", "unbinned"); '
                'the "exhaustive" method returns the N-row Contact'
            )

    # -- host ---------------------------------------------------------------

    def allocate(
        self,
        x: Array,
        surface: Surface,
        *,
        x_prev: Array | None = None,
        mask: Array | None = None,
        at_least: SearchState | Sizes | None = None,
        pool: Array | None = None,
        pairs: Pairs | None = None,
    ) -> SearchState:
        """Measures the sizes from concrete data on the host and finds the candidates.

        Args:
          x: f[N, 2] slave coordinates, or f[B, N, 2] for a batch of B scenes
            searched under ``vmap`` with one allocation (then ``surface``,
            ``x_prev`` and ``mask`` are batched likewise, or the surface
            shared).
          surface: the master ``Surface``.
          x_prev: f[N, 2] previous positions: size the swept search too.
          mask: optional bool[N], False for padding slaves.
          at_least: a state (or ``Sizes``) that the new sizes must not be
            smaller than: to grow after an overflow without shrinking, or to
            size ahead of need for several configurations (allocate for
            each, passing the last state). With ``track=True`` the new state
            keeps ``at_least``'s slip history (same rows), so a run regrown
            mid-way (``resumable_scan``) loses no friction history.
          pool: optional bool[M]: segments masked now that may become real
            later (a new free surface). They are sized for and listed among
            the candidates as if real, so switching them on neither
            overflows nor finds the candidates again; their nodes must be
            where they will be (finite, indices in range) already.
          pairs: the pair rule (``Pairs``), as for ``closest``: the compact
            form's capacities count the contacts (and crossings) the rule
            lets through. For a batch its arrays are batched as ``mask``.

        Returns:
          A ``SearchState``. Its sizes are static: each distinct sizes
          compiles ``closest`` (``swept``) once.

        Raises:
          ValueError: for a radius of 0 (it finds no penetrating slave), and
            for bad inputs, naming the argument.

        Warns:
          UserWarning: when no slave (path) comes within ``radius + skin`` of
            the box of the master's real segments: the sizes then hold no
            contact, and a later step that comes into contact overflows. And
            (with a radius) when an open chain of the master faces away from
            the slaves near it, by ``validate``'s rule: a floor listed left
            to right under a body, whose normals point into the floor.
        """
        return self._allocate(x, surface, x_prev, mask, at_least, pool, pairs, warn=True)

    def _allocate(
        self, x, surface, x_prev=None, mask=None, at_least=None, pool=None, pairs=None, *, warn
    ) -> SearchState:
        """``allocate``, warning (``warn``) where no slave comes near the master or an
        open chain of it faces away from them, and refusing a radius of 0."""
        if warn and self.radius == 0:
            raise ValueError(
                f"Search(radius=0) cannot serve a closest-point search: {_validate.ZERO_RADIUS}; "
                "a Search(radius=None) searches paths only (swept)"
            )
        if self.radius is None and x_prev is None:
            raise ValueError("allocate needs x_prev= for a Search without a radius (paths only)")
        # Paths first: a bad x_prev is named before the x it shares its checks with.
        queries = {SWEPT: (x_prev, x)} if x_prev is not None else {}
        if self.radius is not None:
            queries[CLOSEST] = (x,)
        return self._allocate_queries(queries, surface, mask, at_least, pool, pairs, warn=warn)

    def _allocate_queries(
        self, queries, surface, mask=None, at_least=None, pool=None, pairs=None, *, warn=True
    ) -> SearchState:
        """The state for ``queries`` (``{Query: points}``, each points f[N, 2] or f[B, N, 2]):
        one ``Sizes`` per query, by its name, and the candidates of the first query
        with a radius. A batch runs the same code, mapped over its scenes."""
        hint = "allocate once outside, or start a state inside with search.init(sizes=...)"
        pairs = _pairs.given(pairs)
        given = (list(queries.values()), surface, mask, pool, pairs)
        _inputs.require_concrete("Search.allocate", given, hint)
        batch = np.shape(next(iter(queries.values()))[-1])[:-2]
        if batch:
            given = _as_batch(*given, batch[0])
            first = jax.tree.map(lambda values: values[0], given)
            self._checked(queries, *first)
            axes = 0
        else:
            given = self._checked(queries, *given)
            axes = None
        points, surface, mask, pool, pairing = given
        queries = dict(zip(queries, points, strict=True))
        sizes, candidates, overflow = {}, None, jnp.zeros(batch, bool)
        if self.method != "exhaustive":
            pooled = _segments.with_pool(surface, pool)
            for query, points in queries.items():
                sized = self._sized(query, points, pooled, mask, at_least, pairing, axes)
                sizes[query.name] = sized
            near = [query for query in queries if query.uses_radius]
            if near:
                find = functools.partial(self._find, sizes=sizes[near[0].name])
                if axes is not None:
                    find = jax.vmap(find, in_axes=(0, 0, _axis(mask), _axis(pool)))
                candidates, overflow = find(queries[near[0]][-1], surface, mask, pool)
            if warn and at_least is None:
                reach = self._reach if near else None
                points = max(queries.values(), key=len)
                x_prev = points[0] if len(points) > 1 else None
                _warn_if_none_near(points[-1], pooled, mask, reach, x_prev)
        if warn and self.radius is not None:
            _warn_if_reversed(queries[CLOSEST][-1], surface, mask, pairing, self.radius)
        x = next(iter(queries.values()))[-1]
        state = self._state(QuerySizes(sizes), candidates, overflow, batch, x)
        return _kept_history(state, at_least)

    def _checked(self, queries, points, surface, mask, pool, pairs):
        """The inputs of one scene checked (``ValueError`` naming the argument), as
        arrays: ``(points of each query, surface, mask, pool, pair rule)``."""
        checked = []
        for query, values in zip(queries, points, strict=True):
            radius = self.radius if query.uses_radius else None
            values, surface, _, mask = query.check(values, surface, radius, mask)
            checked.append(values)
        pool = _inputs.check_mask("pool", pool, surface.segments.shape[0])
        return checked, surface, mask, pool, self._pairing(checked[0][-1], surface, mask, pairs)

    def _pairing(self, x, surface, mask, pairs: Pairs) -> Pairs:
        """The checked pair rule of one (unbatched) call."""
        return _pairs.check(pairs, x, surface, mask)

    def _sized(self, query, points, surface, mask, at_least, pairing, axes) -> Sizes:
        """The sizes of ``query`` for this configuration (the largest over a batch:
        ``axes`` 0), with the list form's capacity where the search is compact, and at
        least ``at_least``'s."""
        query_sizing = query.sizing(points, None if self.radius is None else self._reach)
        measuring = measure if axes is None else measure_batch
        sizes = measuring(points[-1], surface, mask=mask, **query_sizing, **self._sizing)
        sizes = self._fitted(sizes, at_least, query.name, points[-1], surface, mask, query_sizing)
        sizes = dataclasses.replace(sizes, contact_capacity=0)
        if not self.compact:
            return sizes
        radius = jnp.asarray(self.radius, points[-1].dtype) if query.uses_radius else None
        in_axes = None if axes is None else ((0,) * len(points), 0, _axis(mask), 0)
        needed = driver.entries_needed(
            query, points, surface, radius, mask, sizes, pairing, in_axes
        )
        measured = _sizes.with_entries(sizes, needed, self.slack)
        return self._merged(measured, at_least, query.name)

    def init(
        self,
        x: Array,
        surface: Surface,
        *,
        sizes: QuerySizes | None,
        mask: Array | None = None,
        pool: Array | None = None,
    ) -> SearchState:
        """A fresh state with known sizes (from an earlier ``allocate``), under ``jit`` too.

        For a run that starts inside a compiled program: its sizes are static
        (``state.sizes``, hashable; ``None`` for the exhaustive method), the
        candidates are found here (with the masked segments of ``pool``
        listed, as ``allocate`` lists them).
        """
        _, x, mask = _inputs.check_slaves(x, None, mask)
        surface = _inputs.check_surface(surface, x.dtype)
        pool = _inputs.check_mask("pool", pool, surface.segments.shape[0])
        sizes = QuerySizes(sizes)
        candidates, overflow = None, jnp.zeros((), bool)
        closest = sizes.get(CLOSEST.name)
        if closest is not None and self.radius is None:
            raise ValueError(
                "init with closest sizes needs a Search with a radius; this one searches paths"
            )
        for name, given in sizes.items():
            _sizes.check_sizes(given, x.shape[0], for_paths=name == SWEPT.name)
        if closest is not None:
            candidates, overflow = self._find(x, surface, mask, pool, sizes=closest)
        return self._state(sizes, candidates, overflow, (), x)

    def _state(self, sizes, candidates, overflow, batch, x) -> SearchState:
        history = slip = last_active = None
        if self.radius is not None:
            last_active = jnp.full(batch + x.shape[-2:-1], -1, jnp.int32)
        if self.track:
            history = _track.empty_history(x.shape[-2], x.dtype, batch)
            slip = _track.no_slip(x.shape[-2], x.dtype, batch)
        return SearchState(
            history=history,
            slip=slip,
            sizes=sizes,
            candidates=candidates,
            overflow=overflow,
            rebuilds=jnp.zeros(batch, jnp.int32),
            last_rebuild=jnp.zeros(batch, jnp.int32),
            lost=jnp.zeros(batch, jnp.int32),
            last_active=last_active,
            reach=None if self.radius is None else self._reach,
        )

    def _find(self, x, surface, mask, pool, *, sizes: Sizes):
        """``(candidates or None, overflow)``: none are kept without a skin."""
        empty = x.shape[0] == 0 or surface.segments.shape[0] == 0
        if self.skin == 0 or empty:
            return None, jnp.zeros((), bool)
        reach = jnp.asarray(self._reach, x.dtype)
        candidates = _candidates.find_jit(x, surface, reach, mask, sizes=sizes, pool=pool)
        return candidates, candidates.overflow

    @property
    def _reach(self) -> float:
        return self.radius + self.skin

    @property
    def _sizing(self) -> dict:
        use_cells = {"auto": None, "binned": True, "unbinned": False}[self.method]
        return {
            "slack": self.slack,
            "block_size": self.block_size,
            "use_cells": use_cells,
            "cells_above": self.cells_above,
            "chunk_rows": self.chunk_rows,
        }

    def _fitted(self, sizes: Sizes, at_least, name: str, x, surface, mask, query_sizing) -> Sizes:
        """``sizes`` merged with ``at_least``'s, and where the merge changed
        them, with room at the merged cells for this configuration
        (``_sizes.fitted``; ``query_sizing``: ``radius=`` or ``x_prev=``, as
        ``measure``): a capacity holds only at the cells it was measured at."""
        merged = self._merged(sizes, at_least, name)
        if merged == sizes:
            return merged
        return fitted(merged, x, surface, mask=mask, **query_sizing, **self._sizing)

    @staticmethod
    def _merged(sizes: Sizes, at_least, name: str) -> Sizes:
        if isinstance(at_least, SearchState):
            at_least = at_least.sizes
        if at_least is not None and not isinstance(at_least, Mapping):
            raise ValueError(
                "at_least must be a SearchState or its sizes (state.sizes); got "
                f"{type(at_least).__name__}"
            )
        return _sizes.merged(sizes, None if at_least is None else QuerySizes(at_least).get(name))

    # -- traced -------------------------------------------------------------

    def closest(
        self,
        state: SearchState,
        x: Array,
        surface: Surface,
        *,
        mask: Array | None = None,
        radius=None,
        pairs: Pairs | None = None,
    ) -> tuple[Contact | ContactList, SearchState]:
        """The closest master segment of every slave within ``radius``: one step.

        Runs under ``jit``, ``lax.scan``, ``vmap`` and ``grad`` (gradients of
        the gaps and points with respect to ``x`` and ``surface.nodes``, as
        ``all_to_all``'s).

        Args:
          state: from ``allocate`` or the last step.
          x: f[N, 2] slave coordinates, N as allocated.
          surface: the master ``Surface``, of the allocated shapes.
          mask: optional bool[N], False for padding slaves.
          radius: optional traced scalar or f[N] at or under ``search.radius``
            (the default): a slave whose radius exceeds it sets ``overflow``
            (the bucket methods).
          pairs: the pair rule (``Pairs``, ``all_to_all``'s).

        Returns:
          ``(contact, state)``. ``contact`` equals ``all_to_all(x, surface,
          radius=radius, mask=mask, ...)`` whenever ``contact.overflow`` is
          False; when it is True, a contact may be missing: allocate again.
          A compact search returns a ``ContactList`` instead, whose
          ``to_contact(N)`` is that ``Contact``. With ``track=True`` the
          new state's ``slip`` is the ``Slip`` of every slave since the last
          step (``jaxcontact.track``).
        """
        if self.radius is None:
            raise ValueError("closest needs a Search with a radius; this one searches paths only")
        _check_state_type(state)
        radius = self.radius if radius is None else radius
        x, surface, radius, mask = _inputs.check_contact_inputs(x, surface, radius, mask)
        pairing = self._pairing(x, surface, mask, pairs)
        if self.track and state.history is None:
            raise ValueError("state has no slip history: allocate it with this search (track=True)")
        if self.track and state.history.found.shape != x.shape[:1]:
            raise ValueError(
                f"state's slip history has shape {state.history.found.shape} (one per slave); "
                f"x has {x.shape[0]} rows: allocate with this x"
            )
        if self.method == "exhaustive":
            contact = driver.exhaustive(CLOSEST, (x,), surface, radius, mask, pairing)
            return self._finish(contact, state, x, surface, mask)
        self._sizes_of(CLOSEST, state, x)
        self._check_state(state, x, surface)
        contact, state = _closest(self, state, x, surface, mask, radius, pairing)
        return self._finish(contact, state, x, surface, mask)

    def _sizes_of(self, query, state: SearchState, x) -> Sizes:
        """The state's sizes for ``query``, checked against ``x`` and this search's form."""
        sizes = state.sizes.get(query.name)
        if sizes is None:
            how = "with this search (it has a radius)" if query.uses_radius else "with x_prev="
            raise ValueError(f"state has no {query.name} sizes: allocate it {how}")
        _sizes.check_sizes(sizes, x.shape[0], for_paths=not query.uses_radius)
        if bool(sizes.contact_capacity) != self.compact:
            made, wanted = (("compact", "N-row"), ("N-row", "compact"))[self.compact]
            raise ValueError(
                f"state was allocated by a {made} search; this one is {wanted}: "
                "allocate with this search"
            )
        return sizes

    def _finish(self, contact, state: SearchState, x, surface: Surface, mask):
        """Smooth normals and the slip history, where this search asks for them, and
        the contacts lost since the last step."""
        if self.normals is not None:
            contact = _normals.smoothed_jit(contact, x, surface, self.normals.corner)
        if state.last_active is not None:
            last_active, lost = _losses(state.last_active, contact, x, surface, mask)
            state = dataclasses.replace(state, last_active=last_active, lost=state.lost + lost)
        if not self.track:
            return contact, state
        history = _track.history_of(contact, x.shape[0])
        slip = _track.track(state.history, contact, surface)
        return contact, dataclasses.replace(state, history=history, slip=slip)

    def _check_state(self, state: SearchState, x, surface: Surface):
        """The state was allocated by a search of this reach, for these shapes."""

        if state.reach is not None and state.reach < self._reach:
            raise ValueError(
                f"state was allocated by a search reaching radius + skin = {state.reach:g}; "
                f"this one reaches {self._reach:g}: allocate with this search"
            )
        _check_unbatched(state, "closest")
        near = state.candidates
        if near is None:
            return
        expected = {
            "x": (near.reference.shape, near.reference.dtype, x),
            "surface.nodes": (near.nodes.shape, near.nodes.dtype, surface.nodes),
            "surface.segments": (near.indices.shape, near.indices.dtype, surface.segments),
        }
        for name, (shape, dtype, value) in expected.items():
            if (value.shape, value.dtype) != (shape, dtype):
                raise ValueError(
                    f"{name} must have the allocated shape {shape} and dtype {dtype}; "
                    f"got shape {value.shape} and dtype {value.dtype}"
                )

    def swept(
        self,
        state: SearchState,
        x_prev: Array,
        x: Array,
        surface: Surface,
        *,
        mask: Array | None = None,
        pairs: Pairs | None = None,
    ) -> tuple[Crossing | CrossingList, SearchState]:
        """The first crossing of every slave's path ``x_prev -> x`` with the master.

        Returns:
          ``(crossing, state)``; ``crossing`` equals ``swept(x_prev, x,
          surface, mask=mask, ...)`` whenever ``crossing.overflow`` is False.
          A compact search returns a ``CrossingList`` instead, whose
          entries are the crossed rows of that ``Crossing``
          (``crossing.to_crossing(N)`` spreads them back).
        """
        _check_state_type(state)
        points, surface, _, mask = SWEPT.check((x_prev, x), surface, None, mask)
        pairing = self._pairing(points[-1], surface, mask, pairs)
        if self.method == "exhaustive":
            return driver.exhaustive(SWEPT, points, surface, None, mask, pairing), state
        return self._step(SWEPT, state, points, surface, None, mask, pairing)

    def _step(self, query, state: SearchState, points, surface, radius, mask, pairing):
        """``query`` searched at the state's sizes: ``(result, state)`` (any query;
        ``closest`` adds the candidates' reuse, the radius bound and the slip)."""
        _check_unbatched(state, query.name)
        sizes = self._sizes_of(query, state, points[-1])
        result = driver.sized_jit(query, points, surface, radius, mask, sizes=sizes, pairs=pairing)
        return result, dataclasses.replace(state, overflow=state.overflow | result.overflow)


def _batched(name: str, values, scene_ndim: int, batch: int):
    """``values`` (one per scene, or shared by the batch) with a leading batch axis."""
    if values is None:
        return None
    values = jnp.asarray(values)
    if values.ndim == scene_ndim:
        return jnp.broadcast_to(values, (batch,) + values.shape)
    if values.ndim != scene_ndim + 1 or values.shape[0] != batch:
        raise ValueError(
            f"{name} must be shared by the batch ({scene_ndim} axes) or have a leading "
            f"batch axis of {batch}; got shape {values.shape}"
        )
    return values


def _batched_surface(surface: Surface, batch: int) -> Surface:
    """``surface`` with every field batched: nodes, segments, mask and body may
    each be shared by the batch or given per scene."""
    if not isinstance(surface, Surface):
        raise ValueError(f"surface must be a jaxcontact.Surface; got {type(surface).__name__}")
    return Surface(
        _batched("surface.nodes", surface.nodes, 2, batch),
        _batched("surface.segments", surface.segments, 2, batch),
        _batched("surface.mask", surface.mask, 1, batch),
        _batched("surface.body", surface.body, 1, batch),
    )


def _as_batch(points, surface, mask, pool, pairs: Pairs, batch: int):
    """A batch's inputs, each with a leading axis of ``batch`` scenes (a surface,
    mask, pool or pair rule given once is shared by every scene)."""
    # A batch split over explicit mesh axes cannot be mapped over: whole.
    given = (points, surface, mask, pool, pairs.slave_node, pairs.slave_body)
    points, surface, mask, pool, slave_node, slave_body = replicated(given)
    points = [tuple(map(jnp.asarray, values)) for values in points]
    for values in points:
        for value in values:
            if value.ndim != 3 or value.shape[0] != batch or value.shape[-1] != 2:
                raise ValueError(
                    f"x must have shape (N, 2) or (B, N, 2), as every slave array of a batch; "
                    f"got shape {value.shape}"
                )
    slave_node, slave_body, mask, pool = (
        _batched(name, values, 1, batch)
        for name, values in (
            ("slave_node", slave_node),
            ("slave_body", slave_body),
            ("mask", mask),
            ("pool", pool),
        )
    )
    pairing = Pairs(slave_node, slave_body, pairs.self_contact, pairs.allow)
    return points, _batched_surface(surface, batch), mask, pool, pairing


def _axis(values):
    """``vmap``'s axis of an optional batched input."""
    return None if values is None else 0


def _kept_history(state: SearchState, at_least) -> SearchState:
    """``state`` with ``at_least``'s slip history and last active contacts (a loss
    across a regrowth is still seen), where both track the same rows."""
    if not isinstance(at_least, SearchState):
        return state
    old_active = at_least.last_active
    if state.last_active is not None and old_active is not None:
        if jnp.shape(old_active) == jnp.shape(state.last_active):
            state = dataclasses.replace(state, last_active=old_active)
    old = at_least.history
    if state.history is None or old is None:
        return state
    if jax.tree.map(jnp.shape, old) != jax.tree.map(jnp.shape, state.history):
        raise ValueError(
            f"at_least's slip history has shape {old.found.shape}; this allocation has "
            f"{state.history.found.shape}"
        )
    return dataclasses.replace(state, history=old)


def _warn_if_none_near(x, surface: Surface, mask, reach, x_prev) -> None:
    """A ``UserWarning`` where no real slave (path) comes within ``reach`` (``radius +
    skin``; None for paths only: 0) of the box of the real segments, in any scene of a
    batch (``x`` f[B, N, 2]): the sizes measured then hold no contact.

    Every later step that does come into contact overflows (``state.overflow``) and
    misses contacts: a body allocated at its drop height falls through the floor, and
    even its gradients look right. Only the box is tested, so the warning is never
    false: a slave inside the box but out of reach passes unwarned (the cull keeps its
    block, so the sizes hold at least that block). A batch's sizes are the largest of its
    scenes', so one scene near the master is enough.
    """
    if np.ndim(x) == 3:
        scenes = range(np.shape(x)[0])

        def scene(values, b):
            return None if values is None else np.asarray(values)[b]

        shared = np.ndim(surface.nodes) == 2
        near = any(
            _near(
                scene(x, b),
                surface if shared else jax.tree.map(lambda v, b=b: np.asarray(v)[b], surface),
                scene(mask, b) if np.ndim(mask) == 2 else mask,
                reach,
                scene(x_prev, b),
            )
            for b in scenes
        )
    else:
        near = _near(x, surface, mask, reach, x_prev)
    if near:
        return
    margin = 0.0 if reach is None else float(reach)
    within = "" if reach is None else f"within the reach {margin:g} of "
    warnings.warn(
        f"Search.allocate: no slave {'path ' if x_prev is not None else ''}comes {within}the "
        "master's box, so the sizes it measured hold no contact: a later step that comes "
        "into contact overflows (state.overflow) and misses contacts. Allocate at a "
        "configuration in contact (or pass at_least= a state allocated there), or reallocate "
        "on overflow (jaxcontact.resumable_scan)",
        UserWarning,
        stacklevel=4,
    )


def _warn_if_reversed(x, surface: Surface, mask, pairs: Pairs, radius: float) -> None:
    """A ``UserWarning`` for each open chain of the master whose normals face away from
    the slaves near it (``validate``'s rule, ``_validate.reversed_chains``), in any scene
    of a batch (``x`` f[B, N, 2]; one warning per chain)."""
    x = np.asarray(x)
    scenes = [()] if x.ndim == 2 else [(b,) for b in range(x.shape[0])]
    messages = []

    def scene(values, at, ndim):
        return values if values is None or np.ndim(values) == ndim else np.asarray(values)[at]

    for at in scenes:
        own = Surface(*(scene(v, at, n) for v, n in zip(surface, (2, 2, 1, 1), strict=True)))
        rows = scene(mask, at, 1)
        rows = np.ones(x.shape[-2], bool) if rows is None else np.asarray(rows, bool)
        segments = np.asarray(own.segments)
        real = np.ones(len(segments), bool) if own.mask is None else np.asarray(own.mask, bool)
        rule = Pairs(
            scene(pairs.slave_node, at, 1),
            scene(pairs.slave_body, at, 1),
            pairs.self_contact,
            pairs.allow,
        )
        found = _validate.reversed_chains(
            x[at], own.nodes, segments, real, rows, body=own.body, pairs=rule, radius=radius
        )
        messages += [message for message in found if message not in messages]
    for message in messages:
        warnings.warn(f"Search.allocate: {message}", UserWarning, stacklevel=4)


def _near(x, surface: Surface, mask, reach, x_prev) -> bool:
    """Whether a real slave (path) of one scene comes within ``reach`` of the box of the
    real segments (True where there is nothing to test: no real slave or segment)."""
    nodes, segments = np.asarray(surface.nodes), np.asarray(surface.segments)
    real = np.ones(len(segments), bool) if surface.mask is None else np.array(surface.mask, bool)
    real &= np.all((segments >= 0) & (segments < len(nodes)), axis=-1)
    ends = nodes[segments[real]].reshape(-1, 2)
    ends = ends[np.all(np.isfinite(ends), axis=-1)]
    points = [np.asarray(x)] + ([] if x_prev is None else [np.asarray(x_prev)])
    rows = np.ones(len(points[0]), bool) if mask is None else np.array(mask, bool)
    for values in points:
        rows &= np.all(np.isfinite(values), axis=-1)
    if not (rows.any() and len(ends)):
        return True
    low, high = np.min(points, axis=0)[rows], np.max(points, axis=0)[rows]
    margin = 0.0 if reach is None else float(reach)
    near = np.all((high >= ends.min(axis=0) - margin) & (low <= ends.max(axis=0) + margin), -1)
    return bool(near.any())


@jax.jit
def _losses(last_active, contact, x, surface: Surface, mask):
    """``(active, lost)``: i32[N] the segment each slave is active on now (-1 where
    none), and i32[] how many slaves active at the last step (on ``last_active``) are
    found nowhere now while lying behind that segment, within its span: deeper than the
    radius reaches (``SearchState.lost``). Elementwise over the N rows, with gathers only
    where a slave active at the last step is found nowhere now; a step that overflowed
    counts none (its missing contacts are the overflow's)."""
    num_rows = x.shape[0]
    if isinstance(contact, ContactList):
        rows = jnp.where(contact.found, contact.node, num_rows)
        found = jnp.zeros(num_rows, bool).at[rows].set(True, mode="drop")
        on = jnp.where(contact.active, contact.segment, -1)
        active = jnp.full(num_rows, -1, jnp.int32).at[rows].set(on, mode="drop")
    else:
        found = contact.found
        active = jnp.where(contact.active, contact.segment, -1).astype(jnp.int32)
    num_segments, num_nodes = surface.segments.shape[0], surface.nodes.shape[0]
    if num_segments == 0 or num_nodes == 0:
        return active, jnp.zeros((), jnp.int32)
    # A loss needs a slave active at the last step and found nowhere now, which most
    # steps have none of: the gathers below (the price of the count: 0.7 ms a step on
    # 81,939 slaves, as much as the search) run only then.
    gone = (last_active >= 0) & ~found
    count = jax.lax.cond(
        jnp.any(gone),
        lambda: _lost_behind(last_active, gone, x, surface, mask),
        lambda: jnp.zeros((), jnp.int32),
    )
    return active, jnp.where(contact.overflow, 0, count)


def _lost_behind(last_active, gone, x, surface: Surface, mask):
    """i32[]: how many slaves ``gone`` (active at the last step, found nowhere now) lie
    behind the segment they were active on (``last_active``), within its span."""
    num_segments, num_nodes = surface.segments.shape[0], surface.nodes.shape[0]
    segment = jnp.clip(last_active, 0, num_segments - 1)
    ends = surface.segments[segment]
    real = (last_active >= 0) & jnp.all((ends >= 0) & (ends < num_nodes), axis=-1)
    if surface.mask is not None:
        real &= surface.mask[segment]
    start = surface.nodes[jnp.clip(ends[:, 0], 0, num_nodes - 1)]
    step = surface.nodes[jnp.clip(ends[:, 1], 0, num_nodes - 1)] - start
    # Only flags leave here: no gradient flows through the test.
    rel = jax.lax.stop_gradient(x - start)
    step = jax.lax.stop_gradient(step)
    along = jnp.sum(rel * step, axis=-1)
    within = (along >= 0) & (along <= jnp.sum(step * step, axis=-1))
    behind = rel[:, 0] * step[:, 1] - rel[:, 1] * step[:, 0] < 0
    lost = real & gone & within & behind & _segments.rows_ok(x, mask)
    return jnp.sum(lost, dtype=jnp.int32)


def _check_state_type(state):
    """A ``ValueError`` unless ``state`` is a ``SearchState``."""
    if not isinstance(state, SearchState):
        raise ValueError(
            "state must be the SearchState that search.allocate(x, surface) returned (or the "
            f"last step's); got {type(state).__name__}"
        )


def _check_unbatched(state: SearchState, method: str):
    """A state allocated for a batch is searched under ``vmap``, scene by scene."""
    if np.ndim(state.overflow) != 0:
        raise ValueError(
            f"state was allocated for a batch of {np.shape(state.overflow)[0]} scenes: "
            f"map {method} over it with jax.vmap, over the state's axis 0 too: "
            f"jax.vmap(search.{method}, in_axes=(0, 0, None)) for a batch of x against one "
            "surface"
        )


@functools.partial(jax.jit, static_argnums=0)
@searched_whole(rows="x")
def _closest(search: Search, state: SearchState, x, surface, mask, radius, pairing):
    sizes = state.sizes[CLOSEST.name]
    reach = jnp.asarray(search._reach, x.dtype)
    # A radius past the bound the sizes were built for may miss a contact.
    real = _segments.rows_ok(x, mask)
    if jnp.ndim(radius) == 0:
        # The scalar test apart: where the radius is a constant within the
        # bound it folds to False and the pass over the rows goes. Written
        # elementwise, XLA constant-folds its split reduction over all N rows
        # first (1.35 s of a 3.4 s compile at 10^6 rows).
        beyond = (radius > search.radius) & jnp.any(real)
    else:
        beyond = jnp.any(real & (radius > search.radius))

    def flagged(contact):
        return contact._replace(overflow=contact.overflow | beyond)

    if state.candidates is None:  # no skin: the whole bucket sort, every step
        contact = flagged(driver.sized(CLOSEST, (x,), surface, radius, mask, sizes, pairs=pairing))
        return contact, dataclasses.replace(state, overflow=state.overflow | contact.overflow)
    stale = _candidates.expired(state.candidates, x, surface, mask, search.skin)

    def find_again(x, surface, mask, candidates):
        return _candidates.find(x, surface, reach, mask, sizes, candidates.pool)

    def keep(x, surface, mask, candidates):
        return candidates

    candidates = jax.lax.cond(stale != 0, find_again, keep, x, surface, mask, state.candidates)
    contact = driver.sized(
        CLOSEST, (x,), surface, radius, mask, sizes, candidates=candidates, pairs=pairing
    )
    contact = flagged(contact)
    state = dataclasses.replace(
        state,
        candidates=candidates,
        overflow=state.overflow | contact.overflow,
        rebuilds=state.rebuilds + (stale != 0).astype(jnp.int32),
        last_rebuild=jnp.where(stale != 0, stale, state.last_rebuild),
    )
    return contact, state
