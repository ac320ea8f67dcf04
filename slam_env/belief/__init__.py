"""The belief over the raw stream: its observation encodings (full, egocentric, local),
entropy, swept-area coverage, metrics and overlay, the reward's terms, and the
composable wrappers that compute them over a user's own env."""
