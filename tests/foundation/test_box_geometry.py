"""Closed-form box distances (testbed/geometry/boxes.py) against Drake's generic query on
poses where that query is reliable (boxes of similar size near each other), rotated
boxes included; the compiled kernel against the numpy reference; the slab form."""

import numpy as np
import pytest
from pydrake.geometry import Box
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, CoulombFriction
from pydrake.multibody.tree import SpatialInertia
from pydrake.systems.framework import DiagramBuilder

from testbed.bodies.containers import CONTAINER_TYPES
from testbed.geometry import boxes as bg
from testbed.geometry.rotations import random_rotations

H_CC = CONTAINER_TYPES["1CC"].half_size  # (3,) [m]
H_AA = CONTAINER_TYPES["1AA"].half_size


class TwoBoxes:
    """Two free boxes in a plant; `distance(X_WA, X_WB)` is Drake's signed distance."""

    def __init__(self, h_A, h_B):
        builder = DiagramBuilder()
        plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
        self.bodies = []
        for name, h in (("A", h_A), ("B", h_B)):
            body = plant.AddRigidBody(name, SpatialInertia.SolidBoxWithMass(1.0, *(2 * h)))
            plant.RegisterCollisionGeometry(body, RigidTransform(), Box(*(2 * h)), name, CoulombFriction(0.5, 0.4))
            self.bodies.append(body)
        plant.Finalize()
        self.plant, self.scene_graph = plant, scene_graph
        self.diagram = builder.Build()
        self.context = self.diagram.CreateDefaultContext()

    def query(self, X_WA, X_WB):
        plant_context = self.plant.GetMyContextFromRoot(self.context)
        for body, X in zip(self.bodies, (X_WA, X_WB)):
            self.plant.SetFreeBodyPose(plant_context, body, X)
        return self.scene_graph.get_query_output_port().Eval(self.scene_graph.GetMyContextFromRoot(self.context))

    def distance(self, X_WA, X_WB):
        q = self.query(X_WA, X_WB)
        ids = q.inspector().GetAllGeometryIds()
        return q.ComputeSignedDistancePairClosestPoints(ids[0], ids[1]).distance


def _poses(seed, n, spread):
    rng = np.random.default_rng(seed)
    R = random_rotations(rng, n)
    p = rng.uniform(-spread, spread, size=(n, 3))
    return p, R


def test_penetration_depth_is_exact_for_rotated_boxes():
    """Overlapping rotated container pairs: SAT depth equals Drake's (FCL EPA) depth
    within 1e-6 m (EPA's own tolerance)."""
    pair = TwoBoxes(H_CC, H_AA)
    p, R = _poses(1, 400, 3.0)
    checked = 0
    for p_AB, R_AB in zip(p, R):
        mine = bg.box_box_signed_distance(p_AB[None], R_AB[None], H_CC, H_AA)[0]
        if not -0.5 < mine < 0:  # shallow overlaps: where EPA is reliable
            continue
        drake = pair.distance(RigidTransform(), RigidTransform(RotationMatrix(R_AB), p_AB))
        assert mine == pytest.approx(drake, abs=1e-6)
        checked += 1
    assert checked >= 10


def test_separated_distance_is_a_lower_bound_and_exact_face_on():
    pair = TwoBoxes(H_CC, H_CC)
    p, R = _poses(2, 300, 8.0)
    for p_AB, R_AB in zip(p, R):
        mine = bg.box_box_signed_distance(p_AB[None], R_AB[None], H_CC, H_CC)[0]
        if mine <= 0.01:
            continue
        drake = pair.distance(RigidTransform(), RigidTransform(RotationMatrix(R_AB), p_AB))
        assert mine <= drake + 1e-9  # never above the true distance: no near pair is missed
    # face on (parallel faces, offset sideways and yawed about the shared normal): exact
    for dz, yaw, dx in ((0.3, 0.0, 1.0), (0.01, 0.4, -2.0), (1e-4, 1.2, 0.5)):
        R_AB = RotationMatrix.MakeZRotation(yaw)
        p_AB = np.array([dx, 0.2, 2 * H_CC[2] + dz])
        mine = bg.box_box_signed_distance(p_AB[None], R_AB.matrix()[None], H_CC, H_CC)[0]
        drake = pair.distance(RigidTransform(), RigidTransform(R_AB, p_AB))
        assert mine == pytest.approx(drake, abs=1e-9)
        assert mine == pytest.approx(dz, abs=1e-12)


def test_slab_form_matches_drake_and_the_box_box_test():
    """A tilted container over a 400 x 400 x 2 m slab near its centre (where Drake's
    query works): the slab form is exact, separated or penetrating."""
    slab = np.array([200.0, 200.0, 1.0])
    pair = TwoBoxes(slab, H_CC)
    rng = np.random.default_rng(3)
    for _ in range(30):
        R_SB = RotationMatrix.MakeXRotation(rng.uniform(-0.3, 0.3)) @ RotationMatrix.MakeYRotation(rng.uniform(-0.3, 0.3))
        lowest = np.abs(R_SB.matrix()[2]) @ H_CC
        gap = rng.uniform(-0.05, 0.05)
        p_SB = np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), slab[2] + lowest + gap])
        d, valid = bg.box_slab_signed_distance(p_SB[None], R_SB.matrix()[None], H_CC, slab)
        assert valid[0]
        assert d[0] == pytest.approx(gap, abs=1e-9)
        assert d[0] == pytest.approx(bg.box_box_signed_distance(p_SB[None], R_SB.matrix()[None], slab, H_CC)[0], abs=1e-9)
        drake = pair.distance(RigidTransform(), RigidTransform(R_SB, p_SB))
        assert d[0] == pytest.approx(drake, abs=1e-6)


def test_slab_form_is_refused_off_the_footprint():
    slab = np.array([200.0, 200.0, 1.0])
    p_SB = np.array([[199.0, 0.0, slab[2] + H_CC[2] - 0.01]])  # overhangs the edge
    _, valid = bg.box_slab_signed_distance(p_SB, np.eye(3)[None], H_CC, slab)
    assert not valid[0]


def test_compiled_kernel_matches_the_numpy_reference():
    rng = np.random.default_rng(4)
    m = 12
    h = np.vstack([[200.0, 200.0, 1.0], np.tile(H_CC, (m - 1, 1)) * rng.uniform(0.5, 2.0, size=(m - 1, 3))])
    p = np.vstack([[0.0, 0.0, -1.0], rng.uniform(-6, 6, size=(m - 1, 3)) + [0, 0, 3]])
    R = np.concatenate([np.eye(3)[None], random_rotations(rng, m - 1)])
    pairs = np.array([(a, b) for a in range(m) for b in range(a + 1, m)])
    slab = np.zeros(m, bool)
    slab[0] = True
    for max_distance in (1e-3, 1.0, 100.0):
        ref = bg.pairwise_signed_distances(p, R, h, pairs, slab, max_distance)
        fast = bg.pairwise_signed_distances_fast(p, R, h, pairs, slab, max_distance)
        near = (ref <= max_distance) | (fast <= max_distance)
        np.testing.assert_allclose(fast[near], ref[near], atol=1e-9)
        assert near.any()


def test_near_distances_agree_with_drake_on_a_resting_stack():
    from pydrake.systems.analysis import Simulator

    from testbed import build_scene, load_scenario
    from testbed.contact import extraction as ce

    scene = build_scene(load_scenario("two_stack"))
    context = scene.create_context()
    simulator = Simulator(scene.diagram, context)
    simulator.AdvanceTo(0.05)
    q = scene.scene_graph.get_query_output_port().Eval(scene.scene_graph.GetMyContextFromRoot(context))
    mine = ce.near_distances(q)
    drake = {frozenset((r.id_A, r.id_B)): r.distance for r in q.ComputeSignedDistancePairwiseClosestPoints(ce.NEAR_DISTANCE)}
    assert set(mine) == set(drake) and len(mine) == 2
    # Penetrating pairs are judged against Drake's point-pair depth: its signed-distance query
    # is inexact under penetration (measured at t = 0.05 s on the E = 1e9 Pa stack: -2.42e-5 m
    # where the point-pair depth and ours agree on -3.1078e-5 m to 1e-15 m).
    depth = {frozenset((r.id_A, r.id_B)): -r.depth for r in q.ComputePointPairPenetration()}
    for key in mine:
        reference = depth[key] if key in depth else drake[key]
        assert mine[key] == pytest.approx(reference, abs=1e-6)



def test_the_fast_distances_run_the_native_twin_where_the_install_built_it():
    """CI's install has a C compiler: the twin must be the compiled module, not the numpy
    fallback (which the test above would also pass)."""
    assert bg._PAIRWISE is not None, "testbed.geometry._pairwise was not built: pip install -e . with a C compiler"
    p, R, h = np.zeros((2, 3)), np.tile(np.eye(3), (2, 1, 1)), np.tile(H_CC, (2, 1))
    p[1, 2] = 2 * H_CC[2] - 0.01
    out = np.empty(1)
    bg._PAIRWISE.signed_distances(p, R, h, np.array([[0, 1]], np.int64), np.zeros(2, np.uint8), 1.0, out)
    assert out[0] == pytest.approx(-0.01, abs=1e-12)
    with pytest.raises(IndexError):
        bg._PAIRWISE.signed_distances(p, R, h, np.array([[0, 2]], np.int64), np.zeros(2, np.uint8), 1.0, out)
