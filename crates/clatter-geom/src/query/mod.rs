//! Collision queries between any two shapes (in progress).
