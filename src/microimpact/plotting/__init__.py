"""microimpact.plotting subpackage."""
