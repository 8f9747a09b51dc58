"""The errors manipcad raises for bad input; the CLI turns them into exit status 2."""

from __future__ import annotations


class ManipcadError(ValueError):
    """Base of every error caused by bad input (a file, an argument, a value).

    Pickled whole, whatever a subclass's constructor takes (e.g. raised on a Dask worker
    or in a child process and raised again in the caller's):

    Example:
        >>> import pickle
        >>> e = pickle.loads(pickle.dumps(InputError("arm.yaml", "joints[0].drive", "no R")))
        >>> type(e).__name__, str(e), e.field
        ('InputError', 'arm.yaml: joints[0].drive: no R', 'joints[0].drive')
    """

    def __reduce__(self):
        return _rebuilt, (type(self), self.args, self.__dict__)


def _rebuilt(cls: type, args: tuple, state: dict) -> ManipcadError:
    """A pickled ManipcadError made again without calling its class's constructor."""
    exc = cls.__new__(cls, *args)
    exc.args = args
    exc.__dict__.update(state)
    return exc


class ModelError(ManipcadError):
    """A robot description that is not physical or not consistent.

    Args:
        message: what is wrong, in words.
        field: the offending field when one is known (e.g. ``"R"`` of a drive),
            so that a file loader can name it as ``joints[1].drive.R``; "" if none.
    """

    def __init__(self, message: str = "", field: str = "") -> None:
        self.field = field
        super().__init__(message)


class InputError(ManipcadError):
    """Bad input in a file or argument: names the source, the field and the reason.

    Args:
        source: the file path or argument name.
        field: the dotted path of the offending field ("" for the whole source).
        reason: why it is wrong, in words.
    """

    def __init__(self, source: str, field: str, reason: str) -> None:
        self.source, self.field, self.reason = str(source), field, reason
        where = f"{self.source}: {field}" if field else self.source
        super().__init__(f"{where}: {reason}")


def require_choice(source: str, field: str, value, choices, what: str = "") -> None:
    """Refuse a value that is not one of ``choices`` with one :class:`InputError`.

    Args:
        source, field: as in :class:`InputError`.
        value: the value given.
        choices: the names allowed (strings), in the order the message lists them.
        what: what the value is, in words (default: ``field``).

    Example:
        >>> require_choice("f", "profile", "cubic", ("lin", "cubic"))
        >>> require_choice("f", "profile", "sine", ("lin", "cubic"))
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: f: profile: unknown profile 'sine'; expected one of lin, cubic
    """
    if value not in choices:
        raise InputError(source, field, f"unknown {what or field} {value!r}; expected one of "
                         f"{', '.join(choices)}")


class ManipcadWarning(UserWarning):
    """Input that is usable but questionable, e.g. an inertia tensor that is positive
    semi-definite but breaks the triangle inequality (:class:`InertiaWarning`)."""


class InertiaWarning(ManipcadWarning):
    """A link's inertia tensor is positive semi-definite but its principal moments
    break the triangle inequality (I1 + I2 >= I3): no rigid body has it. Loaded as
    given; a robot file that keeps such published data on purpose says so in the
    tensor's ``note`` and loads without this warning
    (:func:`manipcad.model.robot.inertia_notes` lists them for ``robots show``)."""


def refuse_renamed(func: str, given: dict, **old_to_new: str) -> None:
    """Refuse the keywords a function caught in ``**given``: one clear error naming the new
    name of a renamed keyword, Python's own TypeError for any other.

    Example:
        >>> refuse_renamed("simulate", {"record_every": 10}, record_every="every")
        Traceback (most recent call last):
        ...
        manipcad.errors.ManipcadError: simulate(): 'record_every' is now called 'every'
    """
    for key in given:
        if key in old_to_new:
            raise ManipcadError(f"{func}(): {key!r} is now called {old_to_new[key]!r}")
        raise TypeError(f"{func}() got an unexpected keyword argument {key!r}")
