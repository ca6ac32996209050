//! Frame graph: declared passes and resources, compiled into culled, ordered, synchronized work.
