"""Serving: process settings, the kernels' warm-up, the warming page, the nginx cluster."""
