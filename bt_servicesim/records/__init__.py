"""What a run leaves behind: the tree log, the MCAP recording, drawings and the picture."""
