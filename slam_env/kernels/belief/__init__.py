"""What the active-SLAM step computes from B filters' beliefs: the observation
encodings, the entropy, the swept-area coverage, the diagnostics against the truth,
the divergence rule and the reward, in two step kernels."""
