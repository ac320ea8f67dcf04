"""The active-SLAM step of B worlds after their raw step, in two kernel calls (see
:class:`slam_env.core.active.ActiveCore`): each world's filter, then what the step
reports of its belief. They chain the kernels that the composable wrappers call one by
one; as one call each, a batch of one pays numba's dispatch twice instead of a dozen
times, which cost more than the work."""

from __future__ import annotations

import numpy as np

from slam_env.kernels.base.compiling import borrowing_kernel
from slam_env.kernels.belief.coverage import coverage_step
from slam_env.kernels.belief.diagnostics import POSE_STD, belief_diagnostics
from slam_env.kernels.belief.divergence import count_rejections
from slam_env.kernels.belief.entropy import belief_entropy
from slam_env.kernels.belief.reward import active_slam_reward
from slam_env.kernels.ekf.associated_update import correct, workspaces_fit
from slam_env.kernels.ekf.association_score import score_association
from slam_env.kernels.ekf.filter import predict
from slam_env.kernels.stream.observe import filter_inputs


@borrowing_kernel
def filter_step(
    raw: tuple,
    known: bool,
    touched: np.ndarray,
    stepping: np.ndarray,
    state: tuple,
    config: tuple,
    controls: np.ndarray,
    io: tuple,
    workspaces: tuple,
    associates: bool,
    bookkeeping: tuple,
    scores: tuple,
) -> bool:
    """The filters of the ``touched`` worlds: their inputs read from the raw
    observation, the prediction of the ``stepping`` ones, and the correction of those
    with observations; then what went wrong, the gate's rejections in a row and, where
    the filters associate, the association's scores.

    ``raw``: ``(odometry, detections, ids, det_count, det_true_ids)`` of the raw step;
    ``known``: the filters leave out detections without an ID; ``state``, ``config``,
    ``io``, ``workspaces``: as :func:`slam_env.kernels.ekf.associated_update.correct` takes them,
    ``controls`` (B, c) the prediction's input; ``bookkeeping``: ``(updated, failed,
    counted, in_a_row)``: the worlds corrected, those whose filter failed since the
    reset (only set here), scratch, and the rejections in a row
    (:func:`~slam_env.kernels.belief.divergence.count_rejections`); ``scores``:
    ``(slot_truth, n_before, step, episode)`` of
    :func:`~slam_env.kernels.ekf.association_score.score_association`. Returns False, with
    the filters unchanged, where the workspaces are too small for the correction."""
    odometry, detections, raw_ids, det_count, true_ids = raw
    x, P, n, _, _, _, first, _ = state
    params, modes, _ = config
    z, ids, counts, assigned, _, _, status, _, error = io
    updated, failed, counted, in_a_row = bookkeeping
    slot_truth, n_before, score_step, score_episode = scores
    filter_inputs(
        odometry, detections, raw_ids, touched, controls, z, ids, det_count, counts, known
    )
    for b in range(x.shape[0]):
        updated[b] = touched[b] and counts[b] > 0
    if not workspaces_fit(x.shape[1], counts, updated, z.shape[1], workspaces, associates):
        return False
    for b in range(x.shape[0]):
        n_before[b] = n[b]
    predict(x, P, n, first, controls, params, modes, stepping, error)
    for b in range(x.shape[0]):
        if stepping[b] and error[b] != 0:
            failed[b] = True
    correct(state, config, io, updated, workspaces, associates)
    for b in range(x.shape[0]):
        # A failed update changed nothing: it counts no rejection and scores nothing.
        counted[b] = updated[b] and error[b] == 0
        if updated[b] and error[b] != 0:
            failed[b] = True
    if associates:
        score_association(
            assigned, status, true_ids, counts, n_before, slot_truth, touched, score_step,
            score_episode,
        )  # fmt: skip
    count_rejections(status, counts, counted, in_a_row)
    return True


@borrowing_kernel
def belief_outputs(
    belief: tuple,
    truth: tuple,
    diagnostics: np.ndarray,
    entropy_of: tuple,
    entropy: np.ndarray,
    entropy_ok: np.ndarray,
    passthrough: tuple,
    coverage: tuple | None,
    tail: np.ndarray,
    swept_fraction: np.ndarray,
    reward: tuple,
    touched: np.ndarray,
    stepping: np.ndarray,
) -> int:
    """What the step reports of each ``touched`` world's belief: its diagnostics
    against the truth, its entropy, the raw proximity readings and the swept-area
    memory in the observation's ``tail``, and the reward (:func:`step_reward`).

    ``belief``: ``(x, P, n, slot_to_id)``; ``truth``: ``(slot_truth, poses,
    landmarks)`` as :func:`~slam_env.kernels.belief.diagnostics.belief_diagnostics` takes
    them; ``entropy_of``: ``(slots, floor, prior_log_det, scratch)`` of
    :func:`~slam_env.kernels.belief.entropy.belief_entropy`; ``passthrough``: the (B, k)
    float32 readings copied to the start of ``tail``, in order (an empty (B, 0) array
    for a sensor the env lacks); ``coverage``: the
    :class:`~slam_env.kernels.belief.coverage.CoverageTables` fields then ``(swept, n_swept,
    held, class_counts, new_cells, features, counts)``, whose features (the swept fraction
    first) go after the readings (None: no memory, a swept fraction of 0); ``reward``:
    ``(weights, collided, last, terms, rewards)`` of
    :func:`~slam_env.kernels.belief.reward.active_slam_reward`. Returns how many worlds'
    entropy is left to the caller (Σ not positive definite to the Cholesky factor):
    the reward too is then left, for :func:`step_reward` once the entropy is known."""
    x, P, n, _ = belief
    truth_of_slots, poses, landmarks = truth
    slots, floor, prior_log_det, scratch = entropy_of
    belief_diagnostics(x, P, n, truth_of_slots, poses, landmarks, diagnostics, touched)
    belief_entropy(P, n, slots, floor, prior_log_det, scratch, entropy, entropy_ok, touched)
    at = 0
    for readings in passthrough:
        for b in range(x.shape[0]):
            if touched[b]:
                for k in range(readings.shape[1]):
                    tail[b, at + k] = readings[b, k]
        at += readings.shape[1]
    if coverage is not None:
        (
            cell, bins, pad, footprints, sizes, codes, classes, footprint_classes, swept,
            n_swept, held, class_counts, new_cells, features, counts,
        ) = coverage  # fmt: skip
        coverage_step(
            cell, bins, pad, footprints, sizes, codes, classes, footprint_classes, swept,
            n_swept, held, class_counts, x, True, new_cells, features, counts, touched,
        )  # fmt: skip
        for b in range(x.shape[0]):
            if touched[b]:
                swept_fraction[b] = features[b, 0]
                for k in range(features.shape[1]):
                    tail[b, at + k] = features[b, k]
    left = 0
    for b in range(x.shape[0]):
        if touched[b] and not entropy_ok[b]:
            left += 1
    if left == 0:
        step_reward(reward, entropy, diagnostics, swept_fraction, touched, stepping)
    return left


@borrowing_kernel
def step_reward(
    reward: tuple,
    entropy: np.ndarray,
    diagnostics: np.ndarray,
    swept_fraction: np.ndarray,
    touched: np.ndarray,
    stepping: np.ndarray,
) -> None:
    """The reward of the ``stepping`` worlds; the other ``touched`` ones (new episodes)
    get reward 0 and make this step the baseline of the next (``reward`` as in
    :func:`belief_outputs`)."""
    weights, collided, last, terms, rewards = reward
    active_slam_reward(
        weights, entropy, diagnostics[POSE_STD], collided, swept_fraction, last, terms,
        rewards, stepping,
    )  # fmt: skip
    for b in range(last.shape[0]):
        if touched[b] and not stepping[b]:
            last[b, 0] = entropy[b]
            last[b, 1] = swept_fraction[b]
            terms[b, :] = 0.0
            rewards[b] = 0.0
