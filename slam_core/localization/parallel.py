"""When the scoring kernels run on several threads."""

#: Particle sets at least this large are scored with ``prange`` over particles; smaller ones on one
#: thread, where starting and joining threads would cost more than the work (measured in
#: benchmarks/localization.py).
PARALLEL_MIN_PARTICLES = 10000
