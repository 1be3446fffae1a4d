"""Individual and joint compatibility; JCBB against brute-force enumeration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from omnislam.core.compatibility import (
    UNPAIRED,
    Decision,
    Pairings,
    decide,
    decide_on_kept_support,
    innovation_widening,
    jcbb,
    joint_gates,
)
from omnislam.core.gating import chi_square_gate

#: D2 of the search and of the direct stacked solve agree to this (relative)
D2_RTOL = 1e-9


def translation_pairings(
    sightings_r: np.ndarray,
    landmarks_w: np.ndarray,
    pose_sigma_m: float,
    noise_sigma_m: float,
    groups: np.ndarray | None = None,
) -> Pairings:
    """A linear problem: z_k = l_m - t + noise, the state x = t (2,) with P = sigma^2 I at t = 0.

    Every pairing's innovation is z_k - l_m, its Jacobian dh/dt = -I: the pairings share the
    one translation error, the textbook case of correlated innovations.
    """
    k, m = len(sightings_r), len(landmarks_w)
    nu = sightings_r[:, None, :] - landmarks_w[None, :, :]
    H = np.broadcast_to(-np.eye(2), (k, m, 2, 2)).copy()
    return Pairings(
        innovations=nu,
        jacobians=H,
        covariance=pose_sigma_m**2 * np.eye(2),
        noise=np.broadcast_to(noise_sigma_m**2 * np.eye(2), (k, 2, 2)).copy(),
        groups=np.zeros(k, dtype=np.int64) if groups is None else groups,
    )


def random_pairings(rng: np.random.Generator, k: int, m: int, n: int) -> Pairings:
    """Random linearised problem: SPD P and R, Jacobians and innovations of moderate size."""
    A = rng.standard_normal((n, n))
    P = A @ A.T / n + 0.1 * np.eye(n)
    B = rng.standard_normal((k, 2, 2))
    R = 0.2 * (B @ np.swapaxes(B, 1, 2)) + 0.05 * np.eye(2)
    H = rng.standard_normal((k, m, 2, n))
    nu = 1.5 * rng.standard_normal((k, m, 2))
    return Pairings(nu, H, P, R, rng.integers(0, 2, k))


def brute_force(pairings: Pairings, probability: float) -> tuple[int, float]:
    """Most pairings jointly compatible (each individually compatible), then the least D2."""
    k, m = pairings.sightings, pairings.candidates
    d2_ind = pairings.individual()
    gate_one = chi_square_gate(probability, 2)
    gates = joint_gates(probability, 2, k)
    best = (0, 0.0)
    for assignment in itertools.product(range(-1, m), repeat=k):
        a = np.array(assignment)
        paired = a != UNPAIRED
        if any(d2_ind[i, a[i]] > gate_one for i in np.flatnonzero(paired)):
            continue
        clash = any(
            a[i] == a[j] and pairings.groups[i] == pairings.groups[j]
            for i, j in itertools.combinations(np.flatnonzero(paired), 2)
        )
        if clash:
            continue
        count = int(paired.sum())
        d2 = pairings.joint(a)
        if d2 > gates[count]:
            continue
        if count > best[0] or (count == best[0] and d2 < best[1]):
            best = (count, d2)
    return best


def test_jcbb_equals_brute_force_enumeration(rng):
    for _ in range(40):
        k, m, n = int(rng.integers(1, 5)), int(rng.integers(1, 5)), int(rng.integers(2, 6))
        pairings = random_pairings(rng, k, m, n)
        result = jcbb(pairings, 0.95)
        count, d2 = brute_force(pairings, 0.95)
        assert result.complete
        assert result.pairings == count
        assert result.d2 == pytest.approx(d2, rel=D2_RTOL, abs=1e-12)
        # the incremental D2 is the stacked one
        assert result.d2 == pytest.approx(pairings.joint(result.assignment), rel=D2_RTOL)


def test_joint_test_rejects_a_spurious_pairing_individual_gating_accepts():
    """Two sightings say the pose is 0.8 m off in +x; a clutter detection would need -0.8 m.

    Each of the three is individually compatible with a landmark (the pose is uncertain to
    1 m), so nearest neighbour takes all three; jointly only the two that agree survive.
    """
    landmarks = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    t_true = np.array([0.8, 0.0])
    sightings = np.array([landmarks[0] - t_true, landmarks[1] - t_true, [0.8, 3.0]])
    pairings = translation_pairings(sightings, landmarks, pose_sigma_m=1.0, noise_sigma_m=0.05)
    gate = chi_square_gate(0.99, 2)
    d2 = pairings.individual()
    nearest = np.argmin(d2, axis=1)
    assert np.all(d2[np.arange(3), nearest] <= gate)  # nearest neighbour pairs all three
    np.testing.assert_array_equal(nearest, [0, 1, 2])
    result = jcbb(pairings, 0.99)
    np.testing.assert_array_equal(result.assignment, [0, 1, UNPAIRED])
    assert result.d2 <= chi_square_gate(0.99, 4)
    # forcing all three together is far outside the joint gate
    assert pairings.joint(np.array([0, 1, 2])) > chi_square_gate(0.99, 6)


def test_a_candidate_pairs_once_per_frame_but_across_frames_of_a_window():
    landmarks = np.array([[0.0, 0.0], [10.0, 0.0]])
    sightings = np.array([[0.01, 0.0], [-0.01, 0.0]])  # both near landmark 0
    one_frame = translation_pairings(sightings, landmarks, 0.1, 0.05)
    result = jcbb(one_frame, 0.99)
    assert result.pairings == 1
    two_frames = translation_pairings(sightings, landmarks, 0.1, 0.05, np.array([0, 1]))
    np.testing.assert_array_equal(jcbb(two_frames, 0.99).assignment, [0, 0])


def test_ties_in_pairings_go_to_the_smaller_joint_distance():
    landmarks = np.array([[0.0, 0.0], [0.3, 0.0]])
    sightings = np.array([[0.25, 0.0]])  # compatible with both; nearer to landmark 1
    result = jcbb(translation_pairings(sightings, landmarks, 0.2, 0.05), 0.99)
    np.testing.assert_array_equal(result.assignment, [1])


def test_node_budget_stops_the_search_and_says_so(rng):
    landmarks = rng.uniform(-1, 1, (6, 2))
    sightings = landmarks[rng.permutation(6)] + 0.01 * rng.standard_normal((6, 2))
    pairings = translation_pairings(sightings, landmarks, 2.0, 0.05)
    full = jcbb(pairings, 0.99)
    assert full.complete and full.pairings == 6
    cut = jcbb(pairings, 0.99, max_nodes=3)
    assert not cut.complete and cut.nodes <= 3 + 1


def test_empty_problems():
    empty = Pairings(np.zeros((0, 3, 2)), np.zeros((0, 3, 2, 4)), np.eye(4), np.zeros((0, 2, 2)))
    result = jcbb(empty, 0.99)
    assert result.pairings == 0 and result.complete
    no_candidates = Pairings(
        np.zeros((2, 0, 2)), np.zeros((2, 0, 2, 3)), np.eye(3), np.tile(np.eye(2), (2, 1, 1))
    )
    np.testing.assert_array_equal(jcbb(no_candidates, 0.99).assignment, [UNPAIRED, UNPAIRED])


def test_shapes_are_checked():
    with pytest.raises(ValueError, match="inconsistent shapes"):
        Pairings(np.zeros((2, 3, 2)), np.zeros((2, 3, 2, 4)), np.eye(5), np.zeros((2, 2, 2)))


def test_decisions_new_by_exclusion_ambiguous_and_rejected():
    gate, new_gate = chi_square_gate(0.99, 2), chi_square_gate(0.9999, 2)
    # two sightings near the one landmark of the map, in one frame: one takes it, the other
    # is new although it is inside the landmark's gate (the frame holds two landmarks there)
    one_landmark = translation_pairings(
        np.array([[0.0, 0.0], [0.15, 0.0]]), np.array([[0.05, 0.0]]), 0.05, 0.05
    )
    result = jcbb(one_landmark, 0.99)
    decisions = decide(result, one_landmark.groups, gate, new_gate)
    assert sorted(decisions.tolist()) == [Decision.PAIRED, Decision.NEW]
    # one sighting between two landmarks it cannot tell apart: the best is taken without a
    # margin, dropped as ambiguous with one
    between = translation_pairings(
        np.array([[0.1, 0.0]]), np.array([[0.0, 0.0], [0.21, 0.0]]), 0.1, 0.05
    )
    result = jcbb(between, 0.99)
    assert result.runner_up is not None and result.runner_up_d2 - result.d2 < 1.0
    assert decide(result, between.groups, gate, new_gate)[0] == Decision.PAIRED
    assert decide(result, between.groups, gate, new_gate, 4.6)[0] == Decision.AMBIGUOUS
    # a sighting between the gates of the only landmark
    far = translation_pairings(np.array([[0.0, 0.0]]), np.array([[0.4, 0.0]]), 0.1, 0.05)
    d2 = far.individual()[0, 0]
    assert gate < d2 < new_gate
    assert decide(jcbb(far, 0.99), far.groups, gate, new_gate)[0] == Decision.AMBIGUOUS


def test_a_pairing_jcbb_leaves_out_is_rejected_not_new():
    landmarks = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 3.0]])
    sightings = np.array([landmarks[0] - [0.8, 0], landmarks[1] - [0.8, 0], [0.8, 3.0]])
    pairings = translation_pairings(sightings, landmarks, pose_sigma_m=1.0, noise_sigma_m=0.05)
    result = jcbb(pairings, 0.99)
    decisions = decide(
        result, pairings.groups, chi_square_gate(0.99, 2), chi_square_gate(0.9999, 2)
    )
    np.testing.assert_array_equal(decisions, [Decision.PAIRED, Decision.PAIRED, Decision.REJECTED])


def test_a_kept_pairing_that_leaned_on_a_dropped_one_is_tested_again_alone():
    gate, new_gate = chi_square_gate(0.99, 2), chi_square_gate(0.9999, 2)
    # a pose 3 m uncertain, two sightings 1 m apart: {0 -> a, 1 -> b} fits exactly, {0 -> a,
    # 1 -> c} nearly (c is 5 cm from b), so sighting 1 is ambiguous; alone, sighting 0 fits d
    # better than a, and only the pair {a, b} made a its landmark (carmen-aces frame 221)
    a, b, c, d = [2.0, 0.0], [3.0, 0.0], [3.0, 0.05], [1.5, 0.0]
    sightings = np.array([[0.0, 0.0], [1.0, 0.0]])
    pairings = translation_pairings(sightings, np.array([a, b, c, d]), 3.0, 0.05)
    result = jcbb(pairings, 0.99)
    np.testing.assert_array_equal(result.assignment, [0, 1])
    plain = decide(result, pairings.groups, gate, new_gate, 4.6)
    np.testing.assert_array_equal(plain, [Decision.PAIRED, Decision.AMBIGUOUS])
    widening = innovation_widening(pairings, 0, 0)
    np.testing.assert_allclose(widening, np.sqrt(3.0**2 + 0.05**2) / 0.05, rtol=1e-12)
    again, decisions = decide_on_kept_support(pairings, 0.99, gate, new_gate, 4.6, 20.0)
    np.testing.assert_array_equal(again.assignment, result.assignment)
    np.testing.assert_array_equal(decisions, [Decision.AMBIGUOUS, Decision.AMBIGUOUS])
    # a pairing narrower than the ratio is not held to it: plain decide
    _, narrow = decide_on_kept_support(pairings, 0.99, gate, new_gate, 4.6, widening + 1.0)
    np.testing.assert_array_equal(narrow, plain)
    # a pose 0.5 m uncertain (still 50 times the noise): alone, sighting 0 takes a by a
    # margin (b and c lie 1.3 m off), so its pairing stands
    near = translation_pairings(
        sightings, np.array([[0.3, 0.0], [1.3, 0.0], [1.3, 0.01]]), 0.5, 0.01
    )
    assert innovation_widening(near, 0, 0) > 20.0
    _, kept = decide_on_kept_support(near, 0.99, gate, new_gate, 4.6, 20.0)
    np.testing.assert_array_equal(kept, [Decision.PAIRED, Decision.AMBIGUOUS])


def test_kept_support_changes_nothing_when_decide_drops_nothing(rng):
    gate, new_gate = chi_square_gate(0.99, 2), chi_square_gate(0.9999, 2)
    for _ in range(20):
        pairings = random_pairings(rng, 3, 4, 5)
        result = jcbb(pairings, 0.99)
        plain = decide(result, pairings.groups, gate, new_gate, 4.6)
        _, decisions = decide_on_kept_support(pairings, 0.99, gate, new_gate, 4.6, 1.0)
        dropped = (result.assignment != UNPAIRED) & (plain != Decision.PAIRED)
        if not dropped.any():
            np.testing.assert_array_equal(decisions, plain)
        else:  # it only ever drops more
            assert np.all(decisions[plain != Decision.PAIRED] == plain[plain != Decision.PAIRED])


def reachable_hypotheses(pairings: Pairings, probability: float) -> list[tuple[int, float]]:
    """(pairings, D2_H) of every hypothesis JCBB can reach: each pairing individually
    compatible, no candidate twice in a frame, and every prefix (in sighting order) inside the
    joint gate of its pairings -- the branch and bound's tree, enumerated without a bound."""
    k, m = pairings.sightings, pairings.candidates
    d2_ind = pairings.individual()
    gate_one = chi_square_gate(probability, 2)
    gates = joint_gates(probability, 2, k)
    found = []
    for assignment in itertools.product(range(-1, m), repeat=k):
        a = np.array(assignment)
        paired = np.flatnonzero(a != UNPAIRED)
        if any(d2_ind[i, a[i]] > gate_one for i in paired):
            continue
        if any(
            a[i] == a[j] and pairings.groups[i] == pairings.groups[j]
            for i, j in itertools.combinations(paired, 2)
        ):
            continue
        prefixes_in = True
        for end in range(1, k + 1):
            prefix = np.where(np.arange(k) < end, a, UNPAIRED)
            count = int(np.sum(prefix != UNPAIRED))
            if count and pairings.joint(prefix) > gates[count]:
                prefixes_in = False
                break
        if prefixes_in:
            found.append((len(paired), pairings.joint(a)))
    return found


def test_runner_up_is_the_second_least_d2_among_the_largest_hypotheses(rng):
    """The runner-up ``decide`` weighs against the best has as many pairings as the best and
    the next D2_H: a hypothesis with fewer pairings, or a best dethroned and forgotten, would
    make the ambiguity margin compare the wrong two."""
    checked = 0
    for _ in range(60):
        k, m, n = int(rng.integers(2, 5)), int(rng.integers(2, 5)), int(rng.integers(2, 6))
        pairings = random_pairings(rng, k, m, n)
        result = jcbb(pairings, 0.95)
        found = reachable_hypotheses(pairings, 0.95)
        most = max(count for count, _ in found)
        d2s = sorted(d2 for count, d2 in found if count == most)
        assert result.pairings == most
        if most == 0 or len(d2s) == 1:
            assert result.runner_up is None and result.runner_up_d2 == np.inf
            continue
        checked += 1
        assert result.runner_up is not None
        assert int(np.sum(result.runner_up != UNPAIRED)) == most
        assert result.runner_up_d2 == pytest.approx(d2s[1], rel=D2_RTOL)
        assert pairings.joint(result.runner_up) == pytest.approx(d2s[1], rel=D2_RTOL)
    assert checked >= 10  # the draws hold runner-ups to check


def test_individual_probability_sets_the_gate_of_the_candidates():
    """One pairing with D2 = 4 (chi-square 2 dof: inside the 0.99 gate 9.21, outside the 0.5
    gate 1.39): the joint gate alone pairs it, a narrower individual gate leaves it out."""
    sigma = np.sqrt(0.5)  # S = P + R = 1 (each 0.5 I), so D2 = |nu|^2
    pairings = translation_pairings(np.array([[2.0, 0.0]]), np.array([[0.0, 0.0]]), sigma, sigma)
    assert pairings.individual()[0, 0] == pytest.approx(4.0, rel=1e-12)
    assert jcbb(pairings, 0.99).pairings == 1
    assert jcbb(pairings, 0.99, individual_probability=0.5).pairings == 0


def test_innovation_widening_is_the_largest_generalised_std(rng):
    """sqrt of the largest eigenvalue of R^-1 S (S = H P H^T + R), against scipy's generalised
    symmetric eigensolver; an anisotropic case makes the largest differ from the smallest."""
    from scipy.linalg import eigh

    for _ in range(10):
        pairings = random_pairings(rng, 2, 3, 4)
        H, R = pairings.jacobians[1, 2], pairings.noise[1]
        S = H @ pairings.covariance @ H.T + R
        expected = np.sqrt(eigh(S, R, eigvals_only=True)[-1])
        assert innovation_widening(pairings, 1, 2) == pytest.approx(expected, rel=1e-10)
    # P = diag(4, 1), R = diag(0.01, 0.04), H = -I: R^-1 S = diag(401, 26)
    anisotropic = Pairings(
        np.zeros((1, 1, 2)),
        -np.eye(2)[None, None],
        np.diag([4.0, 1.0]),
        np.diag([0.01, 0.04])[None],
    )
    assert innovation_widening(anisotropic, 0, 0) == pytest.approx(np.sqrt(401.0), rel=1e-12)
