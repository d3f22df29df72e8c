//! STUB: filled by its helper.
