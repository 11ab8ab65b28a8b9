"""The Shape tab: locating and sizing an extended magnetic target."""
