"""The Layout design tab: CRLB maps of a layout, spacing, optimised layouts, drag previews."""
