"""Pictures and reports: 2D scenes and animations, (later) plots, 3D renders and the HTML report."""
