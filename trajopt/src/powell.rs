//! Powell's method (being written; see the issue tracker).
