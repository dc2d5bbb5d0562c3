"""TunnelQuake: seismic response of water-filled hydraulic tunnels (rock, lining and water)."""
__version__ = "0.1.0"
