"""The belief over the raw stream: its observation encodings (full, egocentric, local),
entropy, swept-area coverage, metrics and overlay, the reward's terms, and the
composable wrappers that compute them over a user's own env."""

from slam_env.belief import metrics
from slam_env.belief.coverage import CoverageGrid
from slam_env.belief.coverage_wrapper import CoverageWrapper
from slam_env.belief.ekf_wrapper import EKFSLAMWrapper
from slam_env.belief.encodings import EgocentricEncoding, FullEncoding, unpack_full_belief
from slam_env.belief.entropy import BeliefEntropy
from slam_env.belief.overlay import BeliefOverlay
from slam_env.belief.reward import REWARD_TERMS, ActiveSLAMRewardWeights
from slam_env.belief.reward_wrapper import ActiveSLAMReward

__all__ = [
    "REWARD_TERMS",
    "ActiveSLAMReward",
    "ActiveSLAMRewardWeights",
    "BeliefEntropy",
    "BeliefOverlay",
    "CoverageGrid",
    "CoverageWrapper",
    "EKFSLAMWrapper",
    "EgocentricEncoding",
    "FullEncoding",
    "metrics",
    "unpack_full_belief",
]
