// Implemented by the gltf work in progress.
