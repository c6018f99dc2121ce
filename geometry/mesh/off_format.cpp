// Implemented by the off work in progress.
