"""Tracking: motion models, the filters, the PCRLB and the Monte-Carlo experiments.

:mod:`.motion` (DWNA model, tracks), :mod:`.filters` (EKF, PUEKF), :mod:`.bank` (the filter
bank of seed 001), :mod:`.pcrlb` (the posterior Cramér–Rao bound), :mod:`.unscented` (UKF,
NHUKF) and :mod:`.montecarlo` (TRMSE against the PCRLB on seed 001's cases).
"""
