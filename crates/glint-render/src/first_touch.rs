//! Frame buffers grown on every thread: a freshly allocated buffer's pages are mapped on
//! their first write, one fault per 4 KiB page, so filling a 50 MB buffer from one thread
//! costs a single-frame render (the command line's) tens of milliseconds that a reused
//! buffer (the viewer's, a benchmark's) never pays. Growing it with rayon's indexed
//! `par_extend` writes the new elements, and so takes the faults, on every thread.

use rayon::prelude::*;

/// [`Vec::resize`], with the new elements written in parallel.
pub(crate) fn resize<T: Clone + Send + Sync>(v: &mut Vec<T>, len: usize, value: T) {
    if len <= v.len() {
        v.truncate(len);
    } else {
        let grow = len - v.len();
        v.par_extend(rayon::iter::repeat_n(value, grow));
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn resize_keeps_the_old_elements_and_fills_the_new_ones() {
        let mut v = vec![1u32, 2, 3];
        super::resize(&mut v, 100_000, 7);
        assert_eq!((v.len(), &v[..4], v[99_999]), (100_000, &[1, 2, 3, 7][..], 7));
        assert!(v[3..].iter().all(|&x| x == 7));
        super::resize(&mut v, 2, 0);
        assert_eq!(v, [1, 2]);
    }
}
