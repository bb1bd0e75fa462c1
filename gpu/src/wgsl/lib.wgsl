// The WGSL intrinsic library (sn_*): being written.
