//! Artefact records ([`formats::records`]) as CSV table columns: a scene builds its table from
//! the same column names the artefact's record declaration gives, so the table, the writer and
//! the reader share one spec.

use formats::records::{Record, Values};
use tables::Table;

/// Appends the columns `names` of `rows` to `table`, in that order.
///
/// # Panics
/// On a name that is not a column of `R` (a programming error the scene's tests catch) or a
/// column whose length differs from the table's.
pub fn append<R: Record>(table: Table, rows: &[R], names: &[&str]) -> Table {
    names.iter().fold(table, |t, &name| {
        match R::values(rows, name)
            .unwrap_or_else(|| panic!("`{name}` is not a column of the record"))
        {
            Values::F64(v) => t.with_f64(name, v),
            Values::I64(v) => t.with_i64(name, v),
            Values::Bool(v) => t.with_bool(name, v),
            Values::Text(v) => t.with_str(name, v),
        }
    })
}

/// A table of every column of `rows`, in the record's order.
pub fn table<R: Record>(rows: &[R]) -> Table {
    let names: Vec<&str> = R::COLUMNS.iter().map(|c| c.name).collect();
    append(Table::new(), rows, &names)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::flow_artefact::FlowStop;
    use contact::path::Branch;

    #[test]
    fn columns_keep_their_names_types_and_order() {
        let stop = FlowStop {
            branch: Branch::Unloading,
            index_flowing: 3,
            index_blocked: 2,
            load_flowing: 0.5,
            load_blocked: 0.6,
            conductivity_flowing: 1e-6,
            contact_area_flowing: 0.4,
            contact_area_blocked: 0.45,
        };
        let t = append(
            Table::new(),
            &[stop],
            &["load_blocked", "branch", "index_flowing"],
        );
        let names: Vec<&str> = t.columns().iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["load_blocked", "branch", "index_flowing"]);
        assert_eq!(t.f64("load_blocked").unwrap(), [0.6]);
        assert_eq!(t.str("branch").unwrap(), ["unloading"]);
        assert_eq!(t.i64("index_flowing").unwrap(), [3]);
    }
}
