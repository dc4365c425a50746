//! The data folder: one folder per job (`jobs/<id>/job.json` and its images) and the uploaded
//! scenes (`scenes/`). Every file is written to a temporary name, flushed to disk and renamed
//! into place (and the rename flushed with its folder), so a crash at any moment leaves either
//! the old file or the new one, never half of one; a write that fails (a full disk) leaves the
//! old file and no temporary one.

use std::{
    fs, io,
    io::Write,
    path::{Path, PathBuf},
    sync::atomic::{AtomicU64, Ordering},
};

use crate::job::JobRecord;

/// Suffix of files being written; any left over from a crash are removed at startup.
const TMP_SUFFIX: &str = ".tmp";

/// File in `jobs/` holding the first id no job used, deleted ones included.
const NEXT_ID_FILE: &str = "next-id";

/// Prefix of a job folder being deleted (`jobs/deleting-<id>`).
const DELETING_PREFIX: &str = "deleting-";

/// The service's data folder.
#[derive(Debug)]
pub struct Store {
    root: PathBuf,
    writer: Writer,
    /// Held (locked) while the store is open: two services writing one folder would overwrite
    /// each other's jobs. The operating system releases it when the process ends, however it
    /// ends.
    _lock: fs::File,
}

/// A job folder whose record could not be read at startup: left in place for a person to
/// repair or remove, and shown by the API as an `unreadable` job.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnreadableRecord {
    pub id: u64,
    /// Why, starting with the record's path inside the data folder.
    pub error: String,
}

/// What [`Store::load_jobs`] found.
#[derive(Debug, Default)]
pub struct LoadedJobs {
    /// The readable records, in id order.
    pub records: Vec<JobRecord>,
    /// The job folders without a readable record, in id order.
    pub unreadable: Vec<UnreadableRecord>,
    /// The first id no folder uses, readable or not.
    pub next_id: u64,
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
            writer: Writer::default(),
            _lock: lock,
        })
    }

    /// What writes this store's files (shared with the scene catalog and the image writer).
    pub fn writer(&self) -> &Writer {
        &self.writer
    }

    /// Folder of uploaded scenes.
    pub fn scenes_dir(&self) -> PathBuf {
        self.root.join("scenes")
    }

    /// Folder of job `id`: its record and its images.
    pub fn job_dir(&self, id: u64) -> PathBuf {
        self.root.join("jobs").join(id.to_string())
    }

    /// Writes a job's record atomically: on an error the previous record (if any) is still
    /// the one on disk.
    pub fn write_job(&self, record: &JobRecord) -> io::Result<()> {
        let dir = self.job_dir(record.id);
        fs::create_dir_all(&dir)?;
        let json = serde_json::to_vec_pretty(record).map_err(io::Error::other)?;
        self.writer.write(&dir.join("job.json"), &json)
    }

    /// Deletes job `id`'s folder (record and images), keeping `next_id` as the first id a
    /// later start may use, so the id is never given to another job. The folder is first
    /// renamed out of the jobs' names, one atomic step: a crash then leaves a folder the next
    /// start removes, never a job with half its files.
    pub fn delete_job(&self, id: u64, next_id: u64) -> io::Result<()> {
        let jobs = self.root.join("jobs");
        self.writer
            .write(&jobs.join(NEXT_ID_FILE), next_id.to_string().as_bytes())?;
        let doomed = jobs.join(format!("{DELETING_PREFIX}{id}"));
        fs::rename(self.job_dir(id), &doomed)?;
        if let Err(error) = fs::remove_dir_all(&doomed) {
            tracing::warn!("{}: {error}; removed at the next start", doomed.display());
        }
        Ok(())
    }

    /// Removes what a job whose first record could not be written left behind (its folder,
    /// if it is empty).
    pub fn remove_unstored_job(&self, id: u64) {
        let _ = fs::remove_dir(self.job_dir(id));
    }

    /// Bytes free for this service on the data folder's file system (`None` where the
    /// platform does not say).
    pub fn free_bytes(&self) -> Option<u64> {
        free_bytes(&self.root)
    }

    /// Checks that a file can be created and written in the data folder (and removes it).
    pub fn check_writable(&self) -> io::Result<()> {
        let probe = self.root.join(format!("healthz{TMP_SUFFIX}"));
        self.writer.check(&probe)?;
        let written = fs::File::create(&probe).and_then(|mut file| file.write_all(b"ok"));
        let _ = fs::remove_file(&probe);
        written
    }

    /// Every job folder's record: the readable ones, those that cannot be read (left alone
    /// for a person to look at), and the first id no folder uses. A folder left empty by a
    /// submission whose record was never stored (its client was answered an error) is
    /// removed; its id stays used.
    pub fn load_jobs(&self) -> io::Result<LoadedJobs> {
        let mut loaded = LoadedJobs {
            next_id: 1,
            ..LoadedJobs::default()
        };
        let jobs = self.root.join("jobs");
        // The first id no deleted job used (deleted jobs leave no folder to count).
        if let Some(next) = fs::read_to_string(jobs.join(NEXT_ID_FILE))
            .ok()
            .and_then(|text| text.trim().parse::<u64>().ok())
        {
            loaded.next_id = loaded.next_id.max(next);
        }
        for entry in fs::read_dir(&jobs)? {
            let entry = entry?;
            let dir = entry.path();
            if !dir.is_dir() {
                continue;
            }
            if (entry.file_name().to_str()).is_some_and(|name| name.starts_with(DELETING_PREFIX)) {
                // A deletion a crash interrupted: finish it.
                let _ = fs::remove_dir_all(&dir);
                continue;
            }
            let Some(id) = (entry.file_name().to_str()).and_then(|name| name.parse::<u64>().ok())
            else {
                tracing::warn!("{}: not a job folder; skipped", dir.display());
                continue;
            };
            loaded.next_id = loaded.next_id.max(id + 1);
            remove_temporaries(&dir);
            let relative = format!("jobs/{id}/job.json");
            let unreadable = |error: String| UnreadableRecord {
                id,
                error: format!("{relative}: {error}"),
            };
            let bytes = match fs::read(dir.join("job.json")) {
                Ok(bytes) => bytes,
                Err(error) if error.kind() == io::ErrorKind::NotFound => {
                    if fs::remove_dir(&dir).is_ok() {
                        tracing::info!("jobs/{id}: an empty folder of a job never stored; removed");
                    } else {
                        loaded.unreadable.push(unreadable(
                            "missing, while the folder holds other files".into(),
                        ));
                    }
                    continue;
                }
                Err(error) => {
                    loaded.unreadable.push(unreadable(error.to_string()));
                    continue;
                }
            };
            match serde_json::from_slice::<JobRecord>(&bytes) {
                Ok(record) if record.id == id => loaded.records.push(record),
                Ok(record) => loaded.unreadable.push(unreadable(format!(
                    "holds job {}, not the folder's own",
                    record.id
                ))),
                Err(error) => loaded
                    .unreadable
                    .push(unreadable(format!("not a job record: {error}"))),
            }
        }
        remove_temporaries(&self.scenes_dir());
        loaded.records.sort_by_key(|r| r.id);
        loaded.unreadable.sort_by_key(|r| r.id);
        Ok(loaded)
    }
}

/// Writes files atomically ([`write_atomic_with`]). Tests can make its writes fail as a full
/// disk does; every clone shares that fault.
#[derive(Clone, Default)]
pub struct Writer {
    #[cfg(test)]
    fault: std::sync::Arc<std::sync::Mutex<Option<Fault>>>,
}

/// Which writes fail, and how: given a file's path, the error its write fails with.
#[cfg(test)]
type Fault = Box<dyn FnMut(&Path) -> Option<io::ErrorKind> + Send>;

impl std::fmt::Debug for Writer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Writer")
    }
}

impl Writer {
    /// Writes `bytes` to `path` atomically.
    pub fn write(&self, path: &Path, bytes: &[u8]) -> io::Result<()> {
        self.write_with(path, |tmp| fs::File::create(tmp)?.write_all(bytes))
    }

    /// Like [`Writer::write`], with `write` producing the temporary file (e.g. an image
    /// encoder); it need not flush it.
    pub fn write_with(
        &self,
        path: &Path,
        write: impl FnOnce(&Path) -> io::Result<()>,
    ) -> io::Result<()> {
        write_atomic_with(path, |tmp| {
            write(tmp)?;
            // After the temporary file exists, as a disk filling up mid-write would fail.
            self.check(path)
        })
    }

    /// The injected failure of a write to `path`, if any.
    fn check(&self, _path: &Path) -> io::Result<()> {
        #[cfg(test)]
        if let Some(fault) = self
            .fault
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_mut()
            && let Some(kind) = fault(_path)
        {
            return Err(io::Error::new(kind, format!("injected failure ({kind})")));
        }
        Ok(())
    }

    /// Makes every write fail with `kind` from now on (`None`: succeed again).
    #[cfg(test)]
    pub fn fail_with(&self, kind: Option<io::ErrorKind>) {
        self.fail_when(move |_| kind);
    }

    /// Makes the writes for which `fault` answers an error fail with it.
    #[cfg(test)]
    pub fn fail_when(&self, fault: impl FnMut(&Path) -> Option<io::ErrorKind> + Send + 'static) {
        *self.fault.lock().unwrap_or_else(|e| e.into_inner()) = Some(Box::new(fault));
    }
}

/// Writes a file through a temporary one in the same folder: `write` produces it, it is
/// flushed to the disk, renamed over `path`, and the folder is flushed so the rename lasts.
/// On an error the temporary file is removed and `path` is as it was.
fn write_atomic_with(path: &Path, write: impl FnOnce(&Path) -> io::Result<()>) -> io::Result<()> {
    let tmp = temporary_path(path);
    let result = write(&tmp)
        .and_then(|()| fs::File::open(&tmp)?.sync_all())
        .and_then(|()| fs::rename(&tmp, path));
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
        return result;
    }
    // The new file is in place: a folder that cannot be flushed only makes the rename less
    // certain to survive a power cut, so it is not reported as a failed write.
    #[cfg(unix)]
    if let Some(dir) = path.parent()
        && let Err(error) = fs::File::open(dir).and_then(|dir| dir.sync_all())
    {
        tracing::warn!("flushing {}: {error}", dir.display());
    }
    Ok(())
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

#[cfg(unix)]
fn free_bytes(path: &Path) -> Option<u64> {
    rustix::fs::statvfs(path)
        .ok()
        .map(|stat| stat.f_bavail.saturating_mul(stat.f_frsize))
}

#[cfg(not(unix))]
fn free_bytes(_path: &Path) -> Option<u64> {
    None
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
                priority: 0,
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
        // A crash while writing leaves a temporary file; a torn record, garbage, a record
        // of another job and a missing one beside images are unreadable.
        fs::write(store.job_dir(7).join("job.json.3.tmp"), b"{").unwrap();
        for (id, bytes) in [
            (11, &b"{\"id\": "[..]),
            (12, &b"\x00\xff garbage"[..]),
            (13, &serde_json::to_vec(&record(2)).unwrap()[..]),
        ] {
            fs::create_dir_all(store.job_dir(id)).unwrap();
            fs::write(store.job_dir(id).join("job.json"), bytes).unwrap();
        }
        fs::create_dir_all(store.job_dir(14)).unwrap();
        fs::write(store.job_dir(14).join("image.png"), b"png").unwrap();
        // An empty folder is what a submission whose record was never written leaves.
        fs::create_dir_all(store.job_dir(15)).unwrap();

        let loaded = store.load_jobs().unwrap();
        let ids = |records: &[JobRecord]| records.iter().map(|r| r.id).collect::<Vec<_>>();
        assert_eq!(ids(&loaded.records), [2, 7, 10]);
        assert_eq!(loaded.records[0], record(2));
        // Unreadable folders keep their ids: new jobs never write into them.
        assert_eq!(loaded.next_id, 16);
        let unreadable: Vec<u64> = loaded.unreadable.iter().map(|r| r.id).collect();
        assert_eq!(unreadable, [11, 12, 13, 14], "{:?}", loaded.unreadable);
        for (record, why) in loaded.unreadable.iter().zip([
            "EOF while parsing",
            "not a job record",
            "holds job 2",
            "missing",
        ]) {
            let expected = format!("jobs/{}/job.json: ", record.id);
            assert!(record.error.starts_with(&expected), "{record:?}");
            assert!(record.error.contains(why), "{record:?}");
        }
        assert!(!store.job_dir(15).exists());
        assert!(!store.job_dir(7).join("job.json.3.tmp").exists());

        // One process at a time.
        let error = Store::open(dir.path()).unwrap_err();
        assert!(error.to_string().contains("another gi-server"), "{error}");
        drop(store);
        assert!(Store::open(dir.path()).is_ok());
    }

    #[test]
    fn a_failed_write_keeps_the_previous_record_and_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        store.write_job(&record(1)).unwrap();
        let mut running = record(1);
        running.state = JobState::Running;
        store.writer().fail_with(Some(io::ErrorKind::StorageFull));
        let error = store.write_job(&running).unwrap_err();
        assert_eq!(error.kind(), io::ErrorKind::StorageFull);
        assert!(store.check_writable().is_err());
        let files: Vec<_> = fs::read_dir(store.job_dir(1))
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(files, ["job.json"]);
        assert_eq!(store.load_jobs().unwrap().records, [record(1)]);

        store.writer().fail_with(None);
        store.write_job(&running).unwrap();
        assert_eq!(store.load_jobs().unwrap().records, [running]);
        assert!(store.check_writable().is_ok());
        assert!(store.free_bytes().is_some_and(|free| free > 0));
    }
}
