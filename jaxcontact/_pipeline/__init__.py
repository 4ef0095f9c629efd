"""The stages every search runs, in order; each module does one job.

1. ``inputs``: check shapes and dtypes (``ValueError`` naming the argument).
2. ``segments``: resolve the master's segments to end points; sanitise rows.
3. ``pairs``: the pair rule (``Pairs``), tagged onto rows and segments
   (``outline``: chains and arc lengths for the self-contact window).
4. ``padding``: plain calls padded to size classes and cut back (``sizes``
   measures the static sizes on the host: classes, capacities, merges).
5. ``broad``: the cull of blocks of slaves against the master's box.
6. ``cells`` (with ``sort``): the segments binned into cells; ``candidates``
   keeps the cull and the binning across steps (the skin rule).
7. ``narrow`` (with ``lowest``, and ``tiles`` on an accelerator): each
   row's lowest-scoring pair.
8. ``writeback``: results into N rows or K entries.

``driver`` runs a query (``jaxcontact._query``) down these stages, once for
the exhaustive search and once for the sized bucket sort. ``geometry`` holds
the per-pair kernels, ``rows`` the few-rows fast path, ``placement`` the
handling of arrays sharded over explicit mesh axes.
"""
