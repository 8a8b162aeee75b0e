//! What a run records, per DESIGN §5: for every step the host, plugin, parameters, compute
//! time, correction and full-mesh bytes, each receiving host's transfer and update time, and
//! the hashes. The types are the engine API's (`meshflow_api::engine`), so the CLI reads
//! the same record the engine writes.

pub use meshflow_api::engine::{
    BatchEntry, BatchStatus, BroadcastRecord, Comparison, Divergence, HashClaim, HostLoad,
    InputRecord, PrefetchRecord, ResultRecord, RunRecord, Status, StepRecord, SubmitBatch,
    SummaryRow, Transfer, TransferRecord, Verdict, Verification,
};
