//! MEXEC-style autonomy core (placeholder until the autonomy-core issue lands).
#![no_std]
