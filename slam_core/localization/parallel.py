"""When the scoring kernels run on several threads."""

from slam_core.jit import njit

#: Particle sets at least this large are scored with ``prange`` over particles; smaller ones on one
#: thread, where starting and joining threads would cost more than the work (measured in
#: benchmarks/localization.py).
PARALLEL_MIN_PARTICLES = 10000


def by_particle_count(body):
    """Compile a scoring kernel twice, serial and parallel; returns ``pick(n_particles) -> kernel``."""
    serial = njit(body)
    parallel = njit(parallel=True)(body)

    def pick(n_particles: int):
        return parallel if n_particles >= PARALLEL_MIN_PARTICLES else serial

    return pick
