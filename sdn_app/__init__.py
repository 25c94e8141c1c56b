"""sdn_app package."""
