"""One folder per tab: its computation, view and drag code; a tab imports no other tab."""
