"""Compiled kernels of the batched core: plain numba functions over arrays with a
leading env axis.

A step of B worlds is a few calls to these kernels instead of hundreds of small numpy
calls; the single envs are the case B = 1 of the same code, and the standalone filter
(:mod:`slam_env.ekf`) runs on the same kernels.

Conventions every kernel follows:

* Per-world arrays have the env axis first: ``poses (B, 3)``, ``P (B, d, d)``,
  detections ``(B, D, 2)`` with counts ``(B,)``. Variable-size sets are padded arrays
  with counts or masks, never Python lists.
* float64 for state and geometry, int64 for indices, IDs and counts, ``np.bool_`` for
  masks, float32 only for observation outputs. Arrays are C-contiguous, so that each
  kernel compiles once.
* Outputs are preallocated by the caller and passed in; kernels allocate nothing in
  their loops and touch no Python objects. Those that run at every step (the EKF's and
  every call of an env step) allocate nothing at all, their scratch passed in too, and
  are compiled without numba's reference counting
  (:func:`~slam_env.kernels.base.compiling.borrowing_kernel`).
* Related arrays and constants are grouped in NamedTuples, but a kernel called from
  Python takes their fields as a plain tuple (``tuple(named)``) and rebuilds the
  NamedTuple inside (``Geometry(*fields)``): numba types a NamedTuple argument at
  every call for ~0.3 µs a field, a plain tuple for a fifth of that, and a step is
  made of a few such calls. A core that passes the same arrays at every step can skip
  the typing altogether by pinning the call (:mod:`slam_env.kernels.base.pinning`).
* Kernels draw no random numbers: they take uniforms drawn from each sub-env's own
  ``np_random`` (see :mod:`slam_env.kernels.base.random`), so that every sub-env replays
  the single env with the same seed.
* Each kernel has a plain reference that the tests hold it to (the dense textbook
  filter, pymunk's own queries, the numpy code it replaced).

The subpackages are layers, lowest first, and a kernel imports only from its own layer
or below (``pyproject.toml``'s import contracts check it): :mod:`.base` (compiling,
angles, small linear algebra, random variates, the seeds' models), then :mod:`.world`
(static geometry, segment queries, motion) and :mod:`.ekf` (the filter's prediction,
update and data association), then :mod:`.stream` (odometry, the landmark sensor, the
proximity scan, faults: the raw step), then :mod:`.belief` (encodings, entropy,
coverage, diagnostics, reward: the active-SLAM step). Nothing here imports anything of
``slam_env`` outside ``slam_env.kernels``.
"""
