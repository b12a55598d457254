//! (being written: see the module documentation of `edit`.)
