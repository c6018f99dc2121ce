// Implemented by the ply work in progress.
