//! The polar transform's RTL side (filled in below).
