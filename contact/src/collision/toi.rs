//! Time of impact.
