//! Wavelets (in progress).
