import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from naive_localization import beam_log_lik, likelihood_field_log_lik, march_range
from scipy.ndimage import distance_transform_edt
from scipy.stats import chi2

from slam_core.distance_transform import distance_transform
from slam_core.localization.beam_model import BeamModel, BeamModelParams, cast_ray
from slam_core.localization.beams import select_beams
from slam_core.localization.clustering import main_cluster
from slam_core.localization.kld import adaptive_count, kld_bound, pose_bins
from slam_core.localization.known_map import KnownMap
from slam_core.localization.likelihood_field import LikelihoodFieldModel, LikelihoodFieldParams
from slam_core.occupancy_grid import OccupancyGrid
from slam_core.scan import Scan


def room_grid(res=0.1):
    """A 4 x 3 m room with a pillar, origin at (-1, -0.5)."""
    ny, nx = int(3 / res), int(4 / res)
    occ = np.zeros((ny, nx), bool)
    occ[0, :] = occ[-1, :] = True
    occ[:, 0] = occ[:, -1] = True
    occ[10:14, 25:28] = True
    grid = OccupancyGrid(res, (-1.0, -0.5), shape=occ.shape)
    grid.data[:] = grid.model.l_min
    grid.data[occ] = grid.model.l_max
    grid.data[5:8, 5:8] = 0.0  # an unknown patch
    return grid, occ


masks = st.tuples(st.integers(1, 30), st.integers(1, 30), st.floats(0.0, 0.3), st.integers(0, 2**31))


@settings(max_examples=150, deadline=None)
@given(masks)
def test_edt_matches_scipy(spec):
    ny, nx, density, seed = spec
    rng = np.random.default_rng(seed)
    occ = rng.random((ny, nx)) < density
    occ[rng.integers(ny), rng.integers(nx)] = True
    assert np.allclose(distance_transform(occ, 0.05), distance_transform_edt(~occ) * 0.05)


def test_edt_without_obstacles_is_infinite():
    assert np.all(np.isinf(distance_transform(np.zeros((3, 4), bool))))


def test_known_map_classifies_cells_and_samples_only_free_space():
    grid, occ = room_grid()
    km = KnownMap(grid)
    assert np.array_equal(km.occupied, occ)
    assert not km.free[5:8, 5:8].any()  # unknown is not free
    poses = km.sample_free_poses(2000, np.random.default_rng(0))
    assert km.is_free(poses[:, :2]).all()
    assert np.all(np.abs(poses[:, 2]) <= np.pi)


def test_known_map_refuses_a_map_without_free_space():
    grid = OccupancyGrid(0.1, shape=(4, 4))
    with pytest.raises(ValueError, match="no free cell"):
        KnownMap(grid)


def make_scan(rng, n=90, range_max=5.0):
    r = rng.uniform(0.2, 6.0, n)
    r[::7] = np.inf
    r[::11] = np.nan
    return Scan(np.linspace(-np.pi, np.pi, n, endpoint=False), r, 0.1, range_max)


def test_select_beams_subsamples_evenly_and_flags_max_readings():
    rng = np.random.default_rng(3)
    scan = make_scan(rng)
    b = select_beams(scan, 30)
    assert len(b) <= 30
    assert np.all(np.isin(b.angles, scan.angles))
    assert np.all(b.max_reading == (b.ranges >= scan.range_max))
    assert np.all(np.isfinite(b.ranges)) and np.all(b.ranges <= scan.range_max)
    assert np.all(np.diff(b.angles) > 0)
    with pytest.raises(ValueError, match="max_beams"):
        select_beams(scan, 0)


def test_likelihood_field_kernel_matches_naive_reference():
    grid, _ = room_grid()
    km = KnownMap(grid)
    params = LikelihoodFieldParams(z_hit=0.8, z_rand=0.2, sigma_hit=0.15, max_dist=1.0)
    model = LikelihoodFieldModel(km, params)
    rng = np.random.default_rng(1)
    beams = select_beams(make_scan(rng), 40)
    particles = np.vstack([km.sample_free_poses(40, rng), [[10.0, 10.0, 0.3]]])  # one far outside
    laser = (0.1, -0.05, 0.2)
    got, used = model.log_likelihood(particles, beams, laser)
    want = likelihood_field_log_lik(particles, laser, beams.angles, beams.ranges, beams.max_reading,
                                    km.distance.astype(float), km.origin, km.resolution,
                                    beams.range_max, 0.8, 0.2, 0.15, 1.0)
    assert used == int((~beams.max_reading).sum())
    assert np.allclose(got, want, rtol=1e-5, atol=1e-4)


def test_likelihood_field_prefers_the_true_pose():
    grid, occ = room_grid(0.05)
    km = KnownMap(grid)
    truth = np.array([0.3, 0.4, 0.5])
    angles = np.linspace(-np.pi, np.pi, 120, endpoint=False)
    ranges = np.array([march_range(occ, km.origin, 0.05, *truth[:2], truth[2] + a, 8.0) for a in angles])
    beams = select_beams(Scan(angles, ranges, 0.05, 8.0), 60)
    offsets = np.array([[0, 0, 0], [0.1, 0, 0], [0, -0.1, 0], [0, 0, 0.1], [0.3, 0.2, -0.2]])
    ll, _ = LikelihoodFieldModel(km).log_likelihood(truth + offsets, beams)
    assert np.argmax(ll) == 0


def test_cast_ray_matches_fine_marching():
    grid, occ = room_grid(0.05)
    km = KnownMap(grid)
    rng = np.random.default_rng(2)
    for x, y, _ in km.sample_free_poses(60, rng):
        h = rng.uniform(-np.pi, np.pi)
        want = march_range(occ, km.origin, 0.05, x, y, h, 3.0)
        got = cast_ray(x, y, math.cos(h), math.sin(h), km.distance, km.origin[0], km.origin[1], 0.05, 3.0)
        # half-cell steps may graze past a corner: at most a few cells late, never early
        assert want - 1e-9 <= got + 0.002 and got <= want + 0.2


def test_beam_model_matches_naive_mixture():
    grid, _occ = room_grid(0.05)
    km = KnownMap(grid)
    p = BeamModelParams()
    model = BeamModel(km, p)
    rng = np.random.default_rng(4)
    beams = select_beams(make_scan(rng, range_max=3.0), 20)
    particles = km.sample_free_poses(5, rng)
    got, used = model.log_likelihood(particles, beams)
    assert used == len(beams)
    for k, (x, y, th) in enumerate(particles):
        want = 0.0
        for a, z, is_max in zip(beams.angles, beams.ranges, beams.max_reading, strict=True):
            exp_r = cast_ray(x, y, math.cos(th + a), math.sin(th + a), km.distance, km.origin[0],
                             km.origin[1], 0.05, beams.range_max)
            want += beam_log_lik(z, exp_r, is_max, beams.range_max, p.z_hit, p.z_short, p.z_max,
                                 p.z_rand, p.sigma_hit, p.lambda_short)
        assert got[k] == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("k", [2, 5, 10, 50, 200, 2000])
def test_kld_bound_is_the_wilson_hilferty_chi_square_quantile(k):
    eps, delta = 0.05, 0.01
    exact = chi2.ppf(1 - delta, k - 1) / (2 * eps)
    assert kld_bound(k, eps, delta) == pytest.approx(exact, rel=0.03 if k > 5 else 0.1, abs=1)


def test_kld_bound_grows_with_bins_and_with_stricter_error():
    k = np.arange(1, 500)
    n = kld_bound(k, 0.05, 0.01)
    assert n[0] == 1 and np.all(np.diff(n) >= 0)
    assert np.all(kld_bound(k, 0.02, 0.01) >= n)


def test_adaptive_count_follows_the_spread():
    rng = np.random.default_rng(0)
    tight = pose_bins(rng.normal([1.2, 1.2, 0.5], [0.01, 0.01, 0.01], (5000, 3)), 0.5, np.radians(10))
    wide = pose_bins(rng.uniform([-20, -20, -np.pi], [20, 20, np.pi], (5000, 3)), 0.5, np.radians(10))
    assert adaptive_count(tight, 0.05, 0.01, 100, 5000) == 100
    assert adaptive_count(wide, 0.05, 0.01, 100, 5000) == 5000
    with pytest.raises(ValueError, match="n_min"):
        adaptive_count(tight, 0.05, 0.01, 0, 10)


def test_main_cluster_picks_the_heavier_blob_and_averages_heading_across_pi():
    rng = np.random.default_rng(5)
    a = np.column_stack([rng.normal(1, 0.05, 300), rng.normal(2, 0.05, 300), rng.normal(np.pi, 0.05, 300)])
    a[:, 2] = (a[:, 2] + np.pi) % (2 * np.pi) - np.pi
    b = np.column_stack([rng.normal(5, 0.05, 500), rng.normal(2, 0.05, 500), rng.normal(0, 0.05, 500)])
    w = np.concatenate([np.full(300, 2.0), np.full(500, 1.0)])
    c = main_cluster(np.vstack([a, b]), w, 0.5, 12)
    assert set(c.members) == set(range(300))
    assert c.weight == pytest.approx(600 / 1100)
    assert c.pose[:2] == pytest.approx([1, 2], abs=0.02)
    assert abs(abs(c.pose[2]) - np.pi) < 0.02
    assert np.sqrt(np.diag(c.covariance)) == pytest.approx([0.05, 0.05, 0.05], rel=0.2)


def test_mcl_public_api_on_a_small_room():
    from slam_core.localization import MclConfig, MonteCarloLocalizer

    grid, occ = room_grid(0.05)
    cfg = MclConfig(min_particles=100, max_particles=2000)
    mcl = MonteCarloLocalizer(grid, cfg, rng=np.random.default_rng(0))
    km = mcl.map
    assert len(mcl.particles) == 2000 and km.is_free(mcl.particles[:, :2]).all()
    assert mcl.occupancy_map() is grid
    assert not mcl.estimate().localized
    truth = np.array([0.5, 0.3, 0.4])
    angles = np.linspace(-np.pi, np.pi, 90, endpoint=False)

    def scan_at(pose):
        r = [march_range(occ, km.origin, 0.05, pose[0], pose[1], pose[2] + a, 8.0, 0.005) for a in angles]
        return Scan(angles, np.array(r), 0.05, 8.0)

    mcl.set_pose(truth, np.diag([0.1, 0.1, 0.1]) ** 2)
    assert mcl.step(np.zeros(3), scan_at(truth))
    mcl.step([0.01, 0.0, 0.0], scan_at(truth))
    assert not mcl.filter_updated  # below update_min_d: no filter update
    step = 0.06  # half of update_min_d and a bit: every second step updates
    for k in range(1, 15):
        pose = truth + k * step * np.array([np.cos(truth[2]), np.sin(truth[2]), 0.0])
        assert mcl.step([k * step, 0.0, 0.0], scan_at(pose))  # the track follows every scan
        assert mcl.filter_updated == (k % 2 == 0)
    e = mcl.estimate()
    assert e.localized
    assert np.hypot(*(e.pose[:2] - pose[:2])) < 0.05 and abs(e.pose[2] - pose[2]) < np.radians(3)
    assert e.covariance.shape == (3, 3) and e.weights.sum() == pytest.approx(1.0)
    assert len(e.particles) == len(e.weights) < 2000  # KLD shrank the set
    with pytest.raises(ValueError, match="covariance"):
        mcl.set_pose(truth, np.eye(2))
    with pytest.raises(ValueError, match="pose must be three"):
        mcl.set_pose([1.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="odometry"):
        mcl.step([0.0, 0.0], scan_at(truth))
    with pytest.raises(ValueError, match="sensor_model"):
        MclConfig(sensor_model="sonar")
    with pytest.raises(ValueError, match="min_particles"):
        MclConfig(min_particles=10, max_particles=5)
