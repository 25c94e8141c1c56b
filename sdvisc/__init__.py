"""sdvisc package."""
