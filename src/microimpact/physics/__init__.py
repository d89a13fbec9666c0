"""microimpact.physics subpackage."""
