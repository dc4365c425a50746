//! How a stored job changes: one function writes the new record, then shows it.

use std::{io, sync::Arc};

use super::{Lane, STORE_RETRY, Service, lock};
use crate::job::JobRecord;

impl Service {
    /// Stores a new job's first record, then shows and queues it. Its id was reserved (and
    /// counted in `storing`) by the submission; a record that cannot be stored leaves nothing
    /// behind and is not shown. Blocking.
    pub(super) fn store_new_job(&self, record: JobRecord, lane: Lane) -> io::Result<JobRecord> {
        let stored = self.store.write_job(&record);
        let mut inner = lock(&self.inner);
        inner.storing -= 1;
        if let Err(error) = stored {
            drop(inner);
            self.store.remove_unstored_job(record.id);
            return Err(error);
        }
        inner.insert(record.clone());
        drop(inner);
        self.metrics.submitted.inc();
        self.enqueue(record.id, lane);
        Ok(record)
    }

    /// The one way a stored job's record changes. `change` edits a copy of job `id`'s record
    /// and says whether it applies (false: the job is not in a state the change is for, and
    /// nothing happens). The copy is written to the data folder, and only once it is there
    /// does it replace the record the API shows: memory never runs ahead of the disk, so a
    /// state the service reported is the state a restart finds. A failed write changes
    /// nothing, on disk or in memory.
    ///
    /// A final state (done, failed, cancelled) is never left: no change to a finished job's
    /// record is stored. Writes of one job are serialized, so the last one stored is the
    /// newest. Answers the new record, or `None` when nothing changed. Blocking.
    pub(super) fn transition_blocking(
        &self,
        id: u64,
        change: impl FnOnce(&mut JobRecord) -> bool,
    ) -> io::Result<Option<JobRecord>> {
        let _write = lock(&self.write_stripes[id as usize % super::WRITE_STRIPES]);
        // Read under the write lock: no other change of this job can come in between.
        let Some(before) = self.record(id) else {
            return Ok(None);
        };
        let mut after = before.clone();
        if !change(&mut after) || after == before {
            return Ok(None);
        }
        if before.state.is_final() {
            tracing::warn!(
                job = id,
                "refused to change a {} job's record (to {})",
                before.state.name(),
                after.state.name()
            );
            return Ok(None);
        }
        self.store.write_job(&after)?;
        lock(&self.inner).commit(after.clone());
        Ok(Some(after))
    }

    /// [`Service::transition_blocking`] on the blocking pool.
    pub(super) async fn transition(
        self: &Arc<Self>,
        id: u64,
        change: impl FnOnce(&mut JobRecord) -> bool + Send + 'static,
    ) -> io::Result<Option<JobRecord>> {
        let service = self.clone();
        tokio::task::spawn_blocking(move || service.transition_blocking(id, change))
            .await
            .map_err(io::Error::other)?
    }

    /// A worker's change that no client waits for (a job's end): tried again every
    /// [`STORE_RETRY`] while the data folder refuses it (a full disk), until it is stored, no
    /// longer applies (the job was cancelled meanwhile), or the service shuts down. Until
    /// then the job shows `running`, as its record on disk says, and its worker waits: no new
    /// work starts while results cannot be kept.
    pub(super) async fn transition_until_stored(
        self: &Arc<Self>,
        id: u64,
        change: impl Fn(&mut JobRecord) -> bool + Clone + Send + 'static,
    ) -> Option<JobRecord> {
        loop {
            // Registered before the attempt, so a shutdown meanwhile still wakes the wait.
            let woken = self.work_ready.notified();
            match self.transition(id, change.clone()).await {
                Ok(changed) => return changed,
                Err(error) if self.is_shutting_down() => {
                    // The record says running: the next start runs the job again.
                    tracing::error!(job = id, "storing the job failed: {error}");
                    return None;
                }
                Err(error) => {
                    tracing::error!(
                        job = id,
                        "storing the job failed: {error}; trying again in {} s",
                        STORE_RETRY.as_secs_f64()
                    );
                    let _ = tokio::time::timeout(STORE_RETRY, woken).await;
                }
            }
        }
    }
}
