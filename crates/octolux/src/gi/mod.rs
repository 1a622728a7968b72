//! Global-illumination techniques, all behind one trait.
