//! CPU reference path tracer: the ground truth every technique is judged against.
