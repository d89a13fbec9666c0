"""microimpact.population subpackage."""
