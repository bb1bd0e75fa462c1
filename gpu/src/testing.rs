//! Test helpers for the GPU back end (device or skip). Being written.
