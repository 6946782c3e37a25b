"""Registration stages on known transforms: Procrustes, RANSAC, ICP, symmetry split."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from helpers import MODELNET, modelnet, random_pose, rotation_error_deg
from pcrp_core.registration import fit_quality, icp, procrustes, procrustes_batch, ransac
from pcrp_core.symmetry import split_halves, symmetry_axis


def test_procrustes_recovers_a_known_rigid_motion():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(50, 3))
    R, t = random_pose(rng)
    R_est, t_est = procrustes(src, src @ R.T + t)
    np.testing.assert_allclose(R_est, R, atol=1e-9)
    np.testing.assert_allclose(t_est, t, atol=1e-9)


def test_procrustes_never_returns_a_reflection():
    rng = np.random.default_rng(1)
    src = rng.normal(size=(30, 3))
    mirrored = src * np.array([1, 1, -1])
    R, _ = procrustes(src, mirrored)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_batched_procrustes_matches_single():
    rng = np.random.default_rng(2)
    src = rng.normal(size=(4, 10, 3))
    dst = rng.normal(size=(4, 10, 3))
    Rb, tb = procrustes_batch(src, dst)
    for k in range(4):
        R, t = procrustes(src[k], dst[k])
        np.testing.assert_allclose(Rb[k], R, atol=1e-10)
        np.testing.assert_allclose(tb[k], t, atol=1e-10)


def test_ransac_ignores_forty_percent_wrong_matches():
    rng = np.random.default_rng(3)
    src = rng.uniform(-1, 1, size=(200, 3))
    R, t = random_pose(rng)
    dst = src @ R.T + t
    wrong = rng.choice(200, 80, replace=False)
    dst[wrong] = rng.uniform(-1, 1, size=(80, 3))
    R_est, t_est, inliers = ransac(src, dst, 0.02, 300, rng)
    assert rotation_error_deg(R_est, R) < 0.01
    assert inliers.sum() >= 120 and not inliers[wrong].any()


@pytest.mark.skipif(not MODELNET.exists(), reason="needs ../shared/data/modelnet40")
def test_icp_converges_from_a_nearby_pose_and_scores_the_fit():
    p = modelnet("chair", count=1)[0][0]
    rng = np.random.default_rng(4)
    from scipy.spatial.transform import Rotation
    R_small = Rotation.from_rotvec(np.radians(12) * np.array([0.6, 0.0, 0.8])).as_matrix()
    tree = cKDTree(p)
    src = p[rng.permutation(len(p))[:400]]
    R, t = icp(src, p, tree, R_small, np.array([0.05, -0.03, 0.02]), iterations=50, trim=0.9)
    assert rotation_error_deg(R, np.eye(3)) < 0.5
    fitness, rmse, chamfer = fit_quality(src @ R.T + t, tree, 0.02)
    assert fitness > 0.95 and chamfer < 0.01
    bad_fit = fit_quality(src @ R_small.T + 0.3, tree, 0.02)
    assert bad_fit[0] < 0.5 and bad_fit[2] > 0.1


def test_symmetry_split_finds_the_mirror_axis_and_halves_it():
    rng = np.random.default_rng(5)
    # a mirror-symmetric shape across x (an L-shape bent in y, z, mirrored in x), arbitrarily rotated
    half = np.column_stack([rng.uniform(0.1, 1, 500), rng.uniform(-2, 2, 500) ** 3 / 4, rng.uniform(-0.5, 1.5, 500) ** 2])
    shape = np.concatenate([half, half * [-1, 1, 1]])
    R, _ = random_pose(rng)
    axis = symmetry_axis(shape @ R.T)
    assert abs(axis @ (R @ [1, 0, 0])) > 0.99
    halves = split_halves(shape @ R.T)
    assert halves.sum() == 500
    assert len(set(halves[:500].tolist())) == 1
