"""TunnelQuake."""
