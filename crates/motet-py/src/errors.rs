//! motet's Python exceptions and how API errors map onto them.

use motet_api::ApiError;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _motet,
    MotetError,
    PyException,
    "Base class of motet's errors."
);
create_exception!(
    _motet,
    MachineFileError,
    MotetError,
    "The machine file is invalid; the message names file:line:column."
);
create_exception!(
    _motet,
    UnreachableError,
    MotetError,
    "The target is beyond travel or cannot be reached by the kinematics."
);
create_exception!(
    _motet,
    UnknownNameError,
    MotetError,
    "No axis or tool has that name."
);
create_exception!(
    _motet,
    ValueOutOfRangeError,
    MotetError,
    "A feed, dwell or tool value is out of range."
);
create_exception!(
    _motet,
    MachineBusyError,
    MotetError,
    "The Machine was used while one of its own calls was still working: from a signal handler or a finalizer that ran during that call."
);

pub fn to_py(e: ApiError) -> PyErr {
    let msg = e.to_string();
    match e {
        ApiError::Machine(_) => MachineFileError::new_err(msg),
        ApiError::Unreachable(_) => UnreachableError::new_err(msg),
        ApiError::UnknownAxis { .. } | ApiError::UnknownTool { .. } => {
            UnknownNameError::new_err(msg)
        }
        ApiError::BadFeed(_) | ApiError::BadDwell(_) | ApiError::BadToolValue(_) => {
            ValueOutOfRangeError::new_err(msg)
        }
        _ => MotetError::new_err(msg),
    }
}

pub fn busy() -> PyErr {
    MachineBusyError::new_err(
        "this Machine is in the middle of a call: it cannot be used from a signal handler or finalizer that runs during one of its own calls",
    )
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("MotetError", py.get_type::<MotetError>())?;
    m.add("MachineFileError", py.get_type::<MachineFileError>())?;
    m.add("UnreachableError", py.get_type::<UnreachableError>())?;
    m.add("UnknownNameError", py.get_type::<UnknownNameError>())?;
    m.add(
        "ValueOutOfRangeError",
        py.get_type::<ValueOutOfRangeError>(),
    )?;
    m.add("MachineBusyError", py.get_type::<MachineBusyError>())?;
    Ok(())
}
