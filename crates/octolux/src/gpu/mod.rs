//! GPU context, pass timers and the memory ledger.
