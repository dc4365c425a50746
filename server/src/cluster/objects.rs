//! Results and uploaded scenes in object storage: `jobs/<id>/<image>` and
//! `scenes/<id>.glb` beside its description `scenes/<id>.json`.
//!
//! `--store-url` names the store: a local folder (`file:///srv/gi` or a plain path, the
//! default), or with gi-server's `s3` feature an S3-compatible bucket (`s3://bucket/prefix`,
//! credentials and endpoint from the usual `AWS_*` environment variables).

use std::sync::Arc;

use bytes::Bytes;
use futures_util::TryStreamExt;
use object_store::{ObjectMeta, ObjectStore, PutPayload, local::LocalFileSystem, path::Path};

use crate::error::ApiError;

/// The store and the prefix everything of this service goes under.
#[derive(Clone)]
pub struct Objects {
    store: Arc<dyn ObjectStore>,
    prefix: Path,
    url: String,
    /// The folder of a local store (which keeps folders emptied by deletions).
    local_root: Option<std::path::PathBuf>,
}

fn store_error(what: &str, error: impl std::fmt::Display) -> ApiError {
    ApiError::new(
        axum::http::StatusCode::SERVICE_UNAVAILABLE,
        "store_unavailable",
        format!("{what}: the object store failed: {error}"),
    )
}

impl Objects {
    /// Opens the store named by `url`.
    pub fn open(url: &str) -> anyhow::Result<Self> {
        let local = url
            .strip_prefix("file://")
            .or_else(|| (!url.contains("://")).then_some(url));
        let local_root = local.map(std::path::PathBuf::from);
        let (store, prefix): (Arc<dyn ObjectStore>, Path) = match local {
            Some(folder) => {
                std::fs::create_dir_all(folder)
                    .map_err(|e| anyhow::anyhow!("creating the store folder {folder}: {e}"))?;
                (
                    Arc::new(LocalFileSystem::new_with_prefix(folder)?),
                    Path::default(),
                )
            }
            None => {
                let parsed =
                    url::Url::parse(url).map_err(|e| anyhow::anyhow!("--store-url {url}: {e}"))?;
                // Credentials, region and endpoint as object_store's builders read them.
                let options = std::env::vars()
                    .filter(|(key, _)| key.starts_with("AWS_"))
                    .map(|(key, value)| (key.to_ascii_lowercase(), value));
                let (store, prefix) =
                    object_store::parse_url_opts(&parsed, options).map_err(|e| {
                        anyhow::anyhow!(
                            "--store-url {url}: {e} (this build knows local folders{})",
                            if cfg!(feature = "s3") {
                                " and s3://"
                            } else {
                                "; S3 needs gi-server built with --features s3"
                            }
                        )
                    })?;
                (Arc::from(store), prefix)
            }
        };
        Ok(Self {
            store,
            prefix,
            url: url.to_string(),
            local_root,
        })
    }

    /// The URL the store was opened with.
    pub fn url(&self) -> &str {
        &self.url
    }

    fn path(&self, key: &str) -> Path {
        key.split('/')
            .fold(self.prefix.clone(), |path, part| path.child(part))
    }

    /// Stores `bytes` at `key` (an object appears whole or not at all).
    pub async fn put(&self, key: &str, bytes: Vec<u8>) -> Result<(), ApiError> {
        self.store
            .put(&self.path(key), PutPayload::from(bytes))
            .await
            .map_err(|e| store_error(&format!("storing {key}"), e))?;
        Ok(())
    }

    /// The object at `key`, `None` if there is none.
    pub async fn get(&self, key: &str) -> Result<Option<Bytes>, ApiError> {
        match self.store.get(&self.path(key)).await {
            Ok(result) => result
                .bytes()
                .await
                .map(Some)
                .map_err(|e| store_error(&format!("reading {key}"), e)),
            Err(object_store::Error::NotFound { .. }) => Ok(None),
            Err(error) => Err(store_error(&format!("reading {key}"), error)),
        }
    }

    /// Deletes the object at `key` (none there is fine).
    pub async fn delete(&self, key: &str) -> Result<(), ApiError> {
        match self.store.delete(&self.path(key)).await {
            Ok(()) | Err(object_store::Error::NotFound { .. }) => Ok(()),
            Err(error) => Err(store_error(&format!("deleting {key}"), error)),
        }
    }

    /// What is stored under `folder`.
    async fn objects(&self, folder: &str) -> Result<Vec<ObjectMeta>, ApiError> {
        self.store
            .list(Some(&self.path(folder)))
            .try_collect()
            .await
            .map_err(|e| store_error(&format!("listing {folder}"), e))
    }

    /// The keys under `folder` (`jobs/12`, `scenes`), relative to the store's prefix.
    pub async fn list(&self, folder: &str) -> Result<Vec<String>, ApiError> {
        let prefix_parts = self.prefix.parts().count();
        Ok((self.objects(folder).await?.into_iter())
            .map(|meta| {
                let parts: Vec<String> = (meta.location.parts().skip(prefix_parts))
                    .map(|p| p.as_ref().to_string())
                    .collect();
                parts.join("/")
            })
            .collect())
    }

    /// Bytes stored under `folder`.
    pub async fn size(&self, folder: &str) -> Result<u64, ApiError> {
        Ok(self
            .objects(folder)
            .await?
            .iter()
            .map(|meta| meta.size)
            .sum())
    }

    /// Deletes everything under `folder` (and, in a local store, the folder once empty).
    pub async fn delete_folder(&self, folder: &str) -> Result<(), ApiError> {
        for key in self.list(folder).await? {
            self.delete(&key).await?;
        }
        if let Some(root) = &self.local_root {
            let _ = std::fs::remove_dir(root.join(folder));
        }
        Ok(())
    }
}

/// Key of job `id`'s image `file`.
pub fn job_key(id: u64, file: &str) -> String {
    format!("jobs/{id}/{file}")
}
