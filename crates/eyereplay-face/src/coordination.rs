//! Eye-head coordination (to come).
