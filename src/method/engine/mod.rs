//! The engine that schedules the stages: what a run needs, planned once per recording
//! ([`setup`]), one frame through every stage ([`worker`]), the noise estimate in frame
//! order ([`sequential`]), and a recording's frames in blocks on several threads with
//! priming ([`analyzer`]).

pub(crate) mod analyzer;
pub(crate) mod sequential;
pub(crate) mod setup;
pub(crate) mod worker;
