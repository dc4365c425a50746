use std::path::PathBuf;

/// Everything that can go wrong while finding, loading or writing a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file is not valid glTF (bad JSON, missing buffer, broken accessor...).
    #[error("{path}: invalid glTF: {message}")]
    Gltf { path: PathBuf, message: String },
    /// Valid glTF whose content the product cannot use (no triangles, bad extras...).
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    /// A lighting file or object that cannot be parsed or applied; `origin` names it.
    #[error("{origin}: invalid lighting: {message}")]
    Lighting { origin: String, message: String },
    #[error("unknown scene '{name}': not a file, and not a bundled scene ({available})")]
    UnknownScene { name: String, available: String },
}
