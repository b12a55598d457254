//! C ABI of libtranscut (see include/transcut.h).
