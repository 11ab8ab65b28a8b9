"""The dashboard's state: param parts, declarations, the scenario, the URL, what applies (no Panel, no Bokeh)."""
