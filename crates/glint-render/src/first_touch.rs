//! Frame buffers grown on every thread: a freshly allocated buffer's pages are mapped on
//! their first write, one fault per 4 KiB page, so filling a 50 MB buffer from one thread
//! costs a single-frame render (the command line's) tens of milliseconds that a reused
//! buffer (the viewer's, a benchmark's) never pays. Growing it with rayon's indexed
//! `par_extend` writes the new elements, and so takes the faults, on every thread.

use glint_core::memory::MemoryError;
use rayon::prelude::*;
use std::sync::Mutex;

/// [`Vec::resize`], with the new elements written in parallel.
pub(crate) fn resize<T: Clone + Send + Sync>(v: &mut Vec<T>, len: usize, value: T) {
    if len <= v.len() {
        v.truncate(len);
    } else {
        let grow = len - v.len();
        v.par_extend(rayon::iter::repeat_n(value, grow));
    }
}

/// `len` copies of `value`: the elements kept from before overwritten, the new ones grown,
/// both on every thread (a reused frame buffer cleared without a page fault).
pub(crate) fn refill<T: Clone + Send + Sync>(v: &mut Vec<T>, len: usize, value: T) {
    v.truncate(len);
    v.par_iter_mut().with_min_len(1024).for_each(|x| *x = value.clone());
    resize(v, len, value);
}

/// One frame buffer kept between frames, so that the next frame of the same size neither maps
/// nor zeroes fresh pages (`static POOL: Pool<T> = Pool::new()` beside the code that uses it).
pub(crate) struct Pool<T>(Mutex<Option<Vec<T>>>);

impl<T: Clone + Send + Sync> Pool<T> {
    pub(crate) const fn new() -> Self {
        Self(Mutex::new(None))
    }

    /// `len` copies of `value`, in the kept buffer when it is large enough (else in a new one,
    /// checked against the memory budget), written on every thread ([`refill`]).
    ///
    /// # Errors
    /// [`MemoryError`] when a new buffer is needed and the budget or the allocator refuses it.
    pub(crate) fn take(&self, len: usize, value: T, what: impl Fn() -> String) -> Result<Vec<T>, MemoryError> {
        let mut v = self.kept_or_new(len, what)?;
        refill(&mut v, len, value);
        Ok(v)
    }

    /// [`Pool::take`] without clearing the kept elements: `len` elements, those kept from the
    /// last frame holding what it left (the new ones `value`). For a caller that writes every
    /// element before it reads one, while it is in cache, instead of a separate pass over the
    /// whole buffer.
    ///
    /// # Errors
    /// As [`Pool::take`].
    pub(crate) fn take_stale(&self, len: usize, value: T, what: impl Fn() -> String) -> Result<Vec<T>, MemoryError> {
        let mut v = self.kept_or_new(len, what)?;
        resize(&mut v, len, value);
        Ok(v)
    }

    /// The kept buffer if it holds `len` elements without growing, else a new empty one of
    /// that capacity (checked against the memory budget).
    fn kept_or_new(&self, len: usize, what: impl Fn() -> String) -> Result<Vec<T>, MemoryError> {
        let kept = self.0.lock().ok().and_then(|mut p| p.take()).filter(|v| v.capacity() >= len);
        match kept {
            Some(v) => Ok(v),
            None => glint_core::memory::try_with_capacity(what, len),
        }
    }

    /// Whether a [`Pool::take`] of `len` elements would reuse the kept buffer.
    pub(crate) fn fits(&self, len: usize) -> bool {
        self.0.lock().is_ok_and(|p| p.as_ref().is_some_and(|v| v.capacity() >= len))
    }

    /// Keep `v` for the next [`Pool::take`] (replacing what was kept: one buffer at most).
    pub(crate) fn give(&self, v: Vec<T>) {
        if let Ok(mut kept) = self.0.lock() {
            *kept = Some(v);
        }
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

    #[test]
    fn refill_overwrites_every_element() {
        let mut v: Vec<u32> = (0..50_000).collect();
        super::refill(&mut v, 70_000, 9);
        assert_eq!(v.len(), 70_000);
        assert!(v.iter().all(|&x| x == 9));
        super::refill(&mut v, 3, 1);
        assert_eq!(v, [1, 1, 1]);
    }

    #[test]
    fn a_pool_hands_back_its_buffer_cleared() {
        static POOL: super::Pool<u64> = super::Pool::new();
        let mut v = POOL.take(1000, 5, String::new).expect("small");
        v[10] = 77;
        let at = v.as_ptr();
        POOL.give(v);
        let again = POOL.take(900, 0, String::new).expect("small");
        assert_eq!((again.as_ptr(), again.len()), (at, 900), "the same memory");
        assert!(!POOL.fits(10), "taken: nothing kept");
        assert!(again.iter().all(|&x| x == 0));
        POOL.give(again);
        assert!(POOL.fits(1000) && !POOL.fits(1001));
        assert_eq!(POOL.take(2000, 1, String::new).expect("small").len(), 2000, "a larger size gets new memory");
    }

    #[test]
    fn a_stale_take_keeps_the_old_elements_and_fills_the_new_ones() {
        static POOL: super::Pool<u32> = super::Pool::new();
        POOL.give(vec![4, 5, 6]);
        assert_eq!(POOL.take_stale(2, 0, String::new).expect("small"), [4, 5]);
        let mut v = POOL.take_stale(3, 9, String::new).expect("small");
        assert_eq!(v, [9, 9, 9], "nothing kept: new elements");
        v.extend([1, 2]);
        POOL.give(v);
        assert_eq!(POOL.take_stale(6, 7, String::new).expect("small"), [9, 9, 9, 1, 2, 7]);
    }
}
