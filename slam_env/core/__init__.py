"""The batched cores: the raw stream of B sub-envs (:mod:`.raw`) and the active-SLAM
stream over it (:mod:`.active`), each a few kernel calls a step, with each sub-env's
randomness from its own generator (:mod:`.random_blocks`). The single envs are the case
B = 1 of the same code."""
