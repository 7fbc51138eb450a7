//! Batched dynamics over many samples (row-major arrays), multi-threaded.
