//! The data folder: one folder per job (`jobs/<id>/job.json` and its images) and the uploaded
//! scenes (`scenes/`). Every file is written to a temporary name, flushed to disk and renamed
//! into place, so a crash at any moment leaves either the old file or the new one, never half
//! of one.

use std::{
    fs, io,
    io::Write,
    path::{Path, PathBuf},
    sync::atomic::{AtomicU64, Ordering},
};

use crate::job::JobRecord;

/// Suffix of files being written; any left over from a crash are removed at startup.
const TMP_SUFFIX: &str = ".tmp";

/// The service's data folder.
#[derive(Debug)]
pub struct Store {
    root: PathBuf,
    /// Held (locked) while the store is open: two services writing one folder would overwrite
    /// each other's jobs. The operating system releases it when the process ends, however it
    /// ends.
    _lock: fs::File,
}

impl Store {
    /// Opens (creating if needed) the data folder at `root`; fails if another process has it
    /// open.
    pub fn open(root: &Path) -> io::Result<Self> {
        fs::create_dir_all(root.join("jobs"))?;
        fs::create_dir_all(root.join("scenes"))?;
        let lock = fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(root.join("lock"))?;
        lock.try_lock().map_err(|error| match error {
            fs::TryLockError::WouldBlock => io::Error::new(
                io::ErrorKind::WouldBlock,
                "another gi-server is using this data folder",
            ),
            fs::TryLockError::Error(error) => error,
        })?;
        Ok(Self {
            root: root.to_path_buf(),
            _lock: lock,
        })
    }

    /// Folder of uploaded scenes.
    pub fn scenes_dir(&self) -> PathBuf {
        self.root.join("scenes")
    }

    /// Folder of job `id`: its record and its images.
    pub fn job_dir(&self, id: u64) -> PathBuf {
        self.root.join("jobs").join(id.to_string())
    }

    /// Writes a job's record atomically.
    pub fn write_job(&self, record: &JobRecord) -> io::Result<()> {
        let dir = self.job_dir(record.id);
        fs::create_dir_all(&dir)?;
        let json = serde_json::to_vec_pretty(record).map_err(io::Error::other)?;
        write_atomic(&dir.join("job.json"), &json)
    }

    /// Every job record in the folder, in id order; a message for each folder that held no
    /// readable record (those are left alone for a person to look at); and the first id that
    /// no folder uses, readable or not.
    pub fn load_jobs(&self) -> io::Result<(Vec<JobRecord>, Vec<String>, u64)> {
        let mut records = Vec::new();
        let mut problems = Vec::new();
        let mut next_id = 1;
        for entry in fs::read_dir(self.root.join("jobs"))? {
            let entry = entry?;
            let dir = entry.path();
            if !dir.is_dir() {
                continue;
            }
            if let Some(id) = entry
                .file_name()
                .to_str()
                .and_then(|name| name.parse::<u64>().ok())
            {
                next_id = next_id.max(id + 1);
            }
            remove_temporaries(&dir);
            let path = dir.join("job.json");
            let parsed = fs::read(&path)
                .map_err(|e| e.to_string())
                .and_then(|bytes| {
                    serde_json::from_slice::<JobRecord>(&bytes).map_err(|e| e.to_string())
                });
            match parsed {
                Ok(record) if dir.file_name() == Some(record.id.to_string().as_ref()) => {
                    records.push(record)
                }
                Ok(record) => problems.push(format!(
                    "{}: holds job {}, not the folder's own",
                    path.display(),
                    record.id
                )),
                Err(error) => problems.push(format!("{}: {error}", path.display())),
            }
        }
        remove_temporaries(&self.scenes_dir());
        records.sort_by_key(|r| r.id);
        Ok((records, problems, next_id))
    }
}

/// Writes `bytes` to `path` through a temporary file in the same folder: written, flushed to
/// the disk, then renamed over `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(path, |tmp| {
        let mut file = fs::File::create(tmp)?;
        file.write_all(bytes)?;
        file.sync_data()
    })
}

/// Like [`write_atomic`], with `write` producing the temporary file (e.g. an image encoder).
pub fn write_atomic_with(
    path: &Path,
    write: impl FnOnce(&Path) -> io::Result<()>,
) -> io::Result<()> {
    let tmp = temporary_path(path);
    let result = write(&tmp).and_then(|()| fs::rename(&tmp, path));
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// A temporary name beside `path`, unique within this process.
fn temporary_path(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(format!(".{n}{TMP_SUFFIX}"));
    path.with_file_name(name)
}

fn remove_temporaries(dir: &Path) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        if entry.file_name().to_string_lossy().ends_with(TMP_SUFFIX) {
            let _ = fs::remove_file(entry.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::{CameraSpec, JobSpec, JobState};

    fn record(id: u64) -> JobRecord {
        JobRecord {
            id,
            spec: JobSpec {
                scene: "cornell-box".to_string(),
                tier: "auto".to_string(),
                width: 8,
                height: 6,
                frames: 1,
                warmup: None,
                spp: 1,
                seed: 1,
                camera: CameraSpec::Named("default".to_string()),
                compare: false,
                reference_spp: None,
                lighting: None,
            },
            state: JobState::Queued,
            submitted_at: "2026-01-01T00:00:00.000Z".to_string(),
            started_at: None,
            finished_at: None,
            attempts: 0,
            failure: None,
            result: None,
        }
    }

    #[test]
    fn records_come_back_in_id_order_and_leftovers_are_reported_or_removed() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        for id in [10, 2, 7] {
            store.write_job(&record(id)).unwrap();
        }
        // A crash while writing leaves a temporary file; one of a torn record is reported.
        fs::write(store.job_dir(7).join("job.json.3.tmp"), b"{").unwrap();
        fs::create_dir_all(store.job_dir(11)).unwrap();
        fs::write(store.job_dir(11).join("job.json"), b"{\"id\": ").unwrap();

        let (records, problems, next_id) = store.load_jobs().unwrap();
        assert_eq!(records.iter().map(|r| r.id).collect::<Vec<_>>(), [2, 7, 10]);
        // The torn record's folder keeps its id: new jobs never write into it.
        assert_eq!(next_id, 12);
        assert_eq!(records[0], record(2));
        assert_eq!(problems.len(), 1, "{problems:?}");
        assert!(problems[0].contains("11"), "{problems:?}");
        assert!(!store.job_dir(7).join("job.json.3.tmp").exists());

        // One process at a time.
        let error = Store::open(dir.path()).unwrap_err();
        assert!(error.to_string().contains("another gi-server"), "{error}");
        drop(store);
        assert!(Store::open(dir.path()).is_ok());
    }
}
