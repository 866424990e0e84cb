//! The interpreter's parameter store: numbered parameters, named globals (`#<_name>`),
//! and the local scope of each subroutine call (`#1`..`#30` and names without a leading
//! `_`), as LinuxCNC scopes them.
//!
//! A subroutine call gets fresh locals: `#1`..`#30` are set from the call's arguments
//! (the rest are 0) and local names start undefined; the caller's locals are restored on
//! return. A Fanuc-style `M98` call shares the caller's `#1`..`#30` (LinuxCNC passes them
//! in and out) but still gets fresh local names. Numbered parameters `#31` and above, and
//! `#<_names>`, are global.
//!
//! Predefined read-only parameters (`#5420` the current X, `#<_units>`, ...) are not
//! stored: the interpreter answers them from its state ([`super::Interp`] implements
//! [`ParamLookup`] over this store).

use crate::expr::MAX_PARAM;
use std::collections::HashMap;

/// Numbered parameters local to a call level (`#1`..`#30`).
pub(crate) const LOCAL_NUMBERED: u32 = 30;

/// One call level's locals.
#[derive(Clone, Debug, Default)]
struct Scope {
    numbered: [Option<f64>; LOCAL_NUMBERED as usize],
    named: HashMap<Box<[u8]>, f64>,
    /// `#1`..`#30` are the caller's (an `M98` call): handed back on return.
    shared: bool,
}

/// Parameter values.
#[derive(Clone, Debug, Default)]
pub(crate) struct Store {
    /// Global numbered parameters (index 0 unused; locals live in the scopes).
    numbered: Vec<Option<f64>>,
    /// `#<_name>` globals.
    globals: HashMap<Box<[u8]>, f64>,
    /// The main program's scope, then one per active call.
    scopes: Vec<Scope>,
}

/// True for a global name (`_` first).
fn is_global(name: &[u8]) -> bool {
    name.first() == Some(&b'_')
}

impl Store {
    pub(crate) fn new() -> Store {
        Store {
            numbered: Vec::new(),
            globals: HashMap::new(),
            scopes: vec![Scope::default()],
        }
    }

    fn scope(&self) -> &Scope {
        // There is always the main scope.
        &self.scopes[self.scopes.len() - 1]
    }

    fn scope_mut(&mut self) -> &mut Scope {
        let n = self.scopes.len() - 1;
        &mut self.scopes[n]
    }

    /// `#index` as stored (`None` when never set).
    pub(crate) fn get(&self, index: u32) -> Option<f64> {
        if (1..=LOCAL_NUMBERED).contains(&index) {
            return self.scope().numbered[index as usize - 1];
        }
        self.numbered.get(index as usize).copied().flatten()
    }

    /// Sets `#index` (`1..=MAX_PARAM`).
    pub(crate) fn set(&mut self, index: u32, value: f64) {
        debug_assert!((1..=MAX_PARAM).contains(&index));
        if (1..=LOCAL_NUMBERED).contains(&index) {
            self.scope_mut().numbered[index as usize - 1] = Some(value);
            return;
        }
        let i = index as usize;
        if i >= self.numbered.len() {
            self.numbered.resize(i + 1, None);
        }
        self.numbered[i] = Some(value);
    }

    /// `#<name>` as stored (upper case, without brackets).
    pub(crate) fn get_named(&self, name: &[u8]) -> Option<f64> {
        if is_global(name) {
            self.globals.get(name).copied()
        } else {
            self.scope().named.get(name).copied()
        }
    }

    /// Sets `#<name>`.
    pub(crate) fn set_named(&mut self, name: &[u8], value: f64) {
        if is_global(name) {
            self.globals.insert(name.into(), value);
        } else {
            self.scope_mut().named.insert(name.into(), value);
        }
    }

    /// Enters a subroutine: fresh locals, `#1..` set from `args` (the others 0).
    pub(crate) fn enter(&mut self, args: &[f64]) {
        let mut s = Scope::default();
        for (i, slot) in s.numbered.iter_mut().enumerate() {
            *slot = Some(args.get(i).copied().unwrap_or(0.0));
        }
        self.scopes.push(s);
    }

    /// Enters an `M98` subprogram: the caller's `#1`..`#30`, fresh local names.
    pub(crate) fn enter_shared(&mut self) {
        let s = Scope {
            numbered: self.scope().numbered,
            named: HashMap::new(),
            shared: true,
        };
        self.scopes.push(s);
    }

    /// Leaves a subroutine: the caller's locals come back (with the values of `#1`..`#30`
    /// an `M98` subprogram left).
    pub(crate) fn leave(&mut self) {
        if self.scopes.len() > 1 {
            if let Some(s) = self.scopes.pop() {
                if s.shared {
                    self.scope_mut().numbered = s.numbered;
                }
            }
        }
    }

    /// Current call depth (0 in the main program).
    pub(crate) fn depth(&self) -> usize {
        self.scopes.len() - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locals_are_scoped_and_globals_shared() {
        let mut s = Store::new();
        s.set(1, 5.0);
        s.set(100, 7.0);
        s.set_named(b"X", 1.0);
        s.set_named(b"_G", 2.0);
        s.enter(&[9.0]);
        assert_eq!(s.get(1), Some(9.0));
        assert_eq!(s.get(2), Some(0.0));
        assert_eq!(s.get(100), Some(7.0));
        assert_eq!(s.get_named(b"X"), None);
        assert_eq!(s.get_named(b"_G"), Some(2.0));
        s.set(1, 3.0);
        s.set(101, 4.0);
        s.set_named(b"_G", 6.0);
        s.leave();
        assert_eq!(s.get(1), Some(5.0));
        assert_eq!(s.get(101), Some(4.0));
        assert_eq!(s.get_named(b"X"), Some(1.0));
        assert_eq!(s.get_named(b"_G"), Some(6.0));
    }

    #[test]
    fn m98_shares_numbered_locals_but_not_names() {
        let mut s = Store::new();
        s.set(1, 5.0);
        s.set_named(b"X", 1.0);
        s.enter_shared();
        assert_eq!(s.get(1), Some(5.0));
        assert_eq!(s.get(2), None);
        assert_eq!(s.get_named(b"X"), None);
        s.set(1, 3.0);
        s.set(30, 4.0);
        s.set_named(b"X", 9.0);
        s.enter(&[]);
        assert_eq!(s.get(1), Some(0.0));
        s.leave();
        s.leave();
        assert_eq!(s.get(1), Some(3.0));
        assert_eq!(s.get(30), Some(4.0));
        assert_eq!(s.get_named(b"X"), Some(1.0));
    }
}
