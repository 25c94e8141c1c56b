"""sdc_unit package."""
