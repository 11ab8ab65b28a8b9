"""The Maps tab: maps A, B and their difference, redrawn in place."""
