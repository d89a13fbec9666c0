"""microimpact.surface subpackage."""
