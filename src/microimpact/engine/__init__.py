"""microimpact.engine subpackage."""
