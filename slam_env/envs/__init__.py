"""The Gymnasium envs: the single envs (:mod:`.landmarks`, :mod:`.active_slam`, sub-env 0
of a batched core, :mod:`.single`), the native vector envs (:mod:`.vector`), what they do
with their options before anything is built (:mod:`.options`), actions and registration."""
