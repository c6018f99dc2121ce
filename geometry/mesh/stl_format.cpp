// Implemented by the stl work in progress.
