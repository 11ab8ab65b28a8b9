"""The Panel dashboard. ``panel serve app`` runs :mod:`app.main`."""
