"""C-frontier map, goal extraction and path planning."""
