"""The Track tab: a straight track over the stations, its PCRLB and trackers."""
