"""The worlds' static geometry as arrays, Chipmunk's segment queries over it, and the
robots' motion: what pymunk computes, reproduced bit for bit for B worlds at once."""
