"""microimpact.io subpackage."""
