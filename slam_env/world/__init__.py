"""The world: layouts (the type, generators, presets, files), the pymunk world and B of
them as arrays, the robots' drive, and frames."""
