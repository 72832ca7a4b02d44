//! Triangle surfaces: loading, repair, inspection and ray casting.
