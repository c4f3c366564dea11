"""What a backend is (:class:`Backend`) and the refusals of the exports: a model whose drives read
table signals, or with controller states, needs gpmegen's runtime, which an export leaves behind."""

from __future__ import annotations

from ...errors import ModelError


class Backend:
    """A backend: the files it writes, the printer of its code, its templates, what it refuses
    and how its output is opened. One subclass per backend, registered by name
    (:func:`gpmegen.codegen.backends.register`).

    A backend that ``folder`` is true of is rendered into a model's folder by
    :func:`gpmegen.codegen.render.render`: each generated function printed by its printer, then
    each of its ``files`` written by :meth:`write` (by default the template ``templates/<file>.j2``).
    ``opened`` is true of the backends the runtime opens from a folder (its openers in
    ``runtime/loader.py``, keyed by the same names); an export's files are opened by other tools.
    """

    #: Its name (``--backend``, ``--format``).
    name: str = ""
    #: The files it writes (of a model's folder, or of an export).
    files: tuple[str, ...] = ()
    #: Rendered into a model's folder (else an export, which writes files of its own).
    folder: bool = False
    #: Opened by the runtime from a folder.
    opened: bool = False
    #: Its functions also cut into blocks of bounded length (:func:`gpmegen.codegen.functions.lower`).
    split: bool = False
    #: What it cannot carry: "signals" (drives reading tables), "controllers" (controller states).
    refuses: tuple[str, ...] = ()
    #: What it makes, in an error line ("an FMU").
    made: str = ""

    def printer(self, parameters, signals=()):
        """The SymPy printer of its code, ``parameters`` the names read from ``p``, ``signals``
        the table signals' names (:mod:`gpmegen.codegen.printers`)."""
        raise NotImplementedError(f"the {self.name} backend prints no functions")

    def templates(self) -> tuple[str, ...]:
        """The templates of ``templates/`` it renders."""
        return tuple(name + ".j2" for name in self.files)

    def write(self, env, functions, context) -> dict[str, str]:
        """Its files (name -> text) of the lowered ``functions``
        (:class:`gpmegen.codegen.functions.Lowered`) and the template ``context``."""
        return {name: env.get_template(template).render(functions=functions, **context)
                for name, template in zip(self.files, self.templates())}

    def check(self, model) -> None:
        """Refuse, in one line, a ``model`` this backend cannot carry (:attr:`refuses`)."""
        if "signals" in self.refuses:
            check_no_signals(model, self.made)
        if "controllers" in self.refuses:
            check_no_controllers(model, self.made)


def check_no_signals(model, export: str) -> None:
    """Refuse, in one line, the export (``export``: what it makes) of a model whose drives read
    table signals: the tables are read at run time by gpmegen's runtime, which an export leaves
    behind."""
    if model is not None and model.signals:
        names = ", ".join(s.name for s in model.signals)
        raise ModelError(f"model {model.name}: its drives read the table signals {names}, which gpmegen's runtime "
                         f"supplies and {export} cannot carry; drive the model through its inputs instead (--inputs)")


def check_no_controllers(model, export: str) -> None:
    """Refuse, in one line, the export (``export``: what it makes) of a model with controller
    states: their rates are integrated by gpmegen's own integrators, which an export leaves
    behind."""
    if model is not None and model.controllers:
        names = ", ".join(c.state for c in model.controllers)
        raise ModelError(f"model {model.name}: {export} does not carry controller states ({names}) yet; "
                         f"simulate it with gpmegen simulate, or write the controller outside the export")
