"""The tabs' shared kit: the off-loop task, the cache, shown rules, number boxes, timings, shared plots."""
