"""RAPID statements as the reader walks them: where a statement starts after the block headers in front of it
(MODULE, PROC, IF ... THEN, a compact IF's condition, CASE n:, labels), the routines the modules define with
their parameters, and RAPID's own instructions, which are not calls of the program's routines.

The statement runs come from `programs.rapid.statements` (the tokens between `;`), so a run holds the headers
and block ends written before its statement: `ENDPROC PROC main() MoveL ...`, `IF x > 3 THEN Set do1`."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

from programs.lexer import Token

INSTRUCTIONS = frozenset(
    {"accset", "actunit", "add", "aliasio", "bitclear", "bitset", "bookerrno", "break", "cancelload"}
    | {"checkprogref", "cirpathmode", "clear", "cleariobuff", "clearpath", "clearrawbytes", "clkreset", "clkstart"}
    | {"clkstop", "close", "closedir", "confj", "confl", "connect", "copyfile", "copyrawbytes", "corrclear"}
    | {"corrcon", "corrdiscon", "corrwrite", "deactunit", "decr", "ditheract", "ditherdeact", "dropwobj"}
    | {"eoffsoff", "eoffson", "eoffsset", "erasemodule", "errlog", "errraise", "errwrite", "exit", "exitcycle"}
    | {"getdataval", "getsysdata", "gettrapdata", "goto", "gripload", "hollowwristreset", "idelete", "idisable"}
    | {"ienable", "ierror", "incr", "indamove", "indcmove", "inddmove", "indreset", "indrmove", "invertdo"}
    | {"iobusstart", "iobusstate", "iodisable", "ioenable", "ipers", "irmqmessage", "isignalai", "isignalao"}
    | {"isignaldi", "isignaldo", "isignalgi", "isignalgo", "isleep", "itimer", "ivarvalue", "iwatch", "load"}
    | {"loadid", "makedir", "manloadidproc", "mechunitload", "motionprocessmodeset", "motionsup", "moveabsj"}
    | {"moveextj", "mtoolrotcalib", "mtooltcpcalib", "open", "opendir", "packdnheader", "packrawbytes"}
    | {"pathacclim", "pathrecmovebwd", "pathrecmovefwd", "pathrecstart", "pathrecstop", "pathresol", "pdispoff"}
    | {"pdispon", "pdispset", "procerrrecovery", "pulsedo", "raise", "raisetouser", "readanybin", "readblock"}
    | {"readcfgdata", "readerrdata", "readrawbytes", "removedir", "removefile", "renamefile", "reset"}
    | {"resetppmoved", "resetretrycount", "restopath", "retry", "return", "rewind", "rmqemptyqueue"}
    | {"rmqfindslot", "rmqgetmessage", "rmqgetmsgdata", "rmqgetmsgheader", "rmqreadwait", "rmqsendmessage"}
    | {"rmqsendwait", "save", "scwrite", "searchc", "searchextj", "searchl", "sendevice", "set", "setalldataval"}
    | {"setao", "setdatasearch", "setdataval", "setdo", "setgo", "setsysdata", "singarea", "skipwarn"}
    | {"socketaccept", "socketbind", "socketclose", "socketconnect", "socketcreate", "socketlisten"}
    | {"socketreceive", "socketreceivefrom", "socketsend", "socketsendto", "softact", "softdeact", "speedlimaxis"}
    | {"speedlimcheckpoint", "speedrefresh", "spystart", "spystop", "startload", "startmove", "startmoveretry"}
    | {"stcalib", "stclose", "stepbwdpath", "stindgun", "stindgunreset", "stoolrotcalib", "stooltcpcalib", "stop"}
    | {"stopen", "stopmove", "stopmovereset", "storepath", "sttune", "sttunereset", "syncmoveoff", "syncmoveon"}
    | {"syncmoveresume", "syncmovesuspend", "syncmoveundo", "synctosensor", "systemstopaction", "testsigndefine"}
    | {"testsignreset", "texttabinstall", "tperase", "tpreaddnum", "tpreadfk", "tpreadnum", "tpshow", "tpwrite"}
    | {"triggc", "triggcheckio", "triggequip", "triggint", "triggio", "triggj", "triggl", "trigglios"}
    | {"triggrampao", "triggspeed", "triggstopproc", "tryint", "trynext", "tunereset", "tuneservo", "uimsgbox"}
    | {"uishow", "unload", "unpackrawbytes", "velset", "waitai", "waitao", "waitdi", "waitdo", "waitgi", "waitgo"}
    | {"waitload", "waitrob", "waitsensor", "waitsynctask", "waittestandset", "waittime", "waituntil", "waitwobj"}
    | {"warmstart", "worldacclim", "write", "writeanybin", "writebin", "writeblock", "writecfgdata"}
    | {"writerawbytes", "writestrbin", "writevar", "wzboxdef", "wzcyldef", "wzdisable", "wzdoset", "wzenable"}
    | {"wzfree", "wzhomejointdef", "wzlimjointdef", "wzlimsup", "wzsphdef", "arcl", "arcc", "arclstart"}
    | {"arclend", "arccstart", "arccend", "spotl", "spotj", "spotml", "capl", "capc", "paintl", "paintc"}
)
"""RAPID's own instructions (the RAPID Instructions reference manual, RobotWare 6, with the arc, spot, dispense
and paint options' motions): a statement starting with one of them is not a call of a routine of the program.
Control flow (IF, WHILE, FOR, TEST) is a block header, read before the statement. CallByVar and late binding
(`%"name" + s%;`) are calls whose routine is known only at run time."""

FRAME_SETTERS = frozenset(
    {"mtooltcpcalib", "mtoolrotcalib", "stooltcpcalib", "stoolrotcalib", "getdataval", "readanybin"}
    | {"unpackrawbytes", "readvar"}
)
"""Instructions that write a datum given as an argument (INOUT): the tool calibrations write the tooldata's
tframe, GetDataVal, ReadAnyBin and UnpackRawBytes the value they read."""

_BLOCK_WORDS = frozenset(
    {"else", "endif", "endwhile", "endfor", "endtest", "endproc", "endfunc", "endtrap", "endmodule"}
    | {"endrecord", "undo", "backward", "error"}
)
_CONDITION_ENDS = {"if": ("then",), "elseif": ("then",), "while": ("do",), "for": ("do",), "test": ("case", "default")}
_OPERATORS = frozenset({"and", "or", "xor", "not", "div", "mod"})
_ROUTINES = frozenset({"proc", "func", "trap"})


@dataclass
class Split:
    """A statement run split into its block headers and its statement."""

    header: list[Token]
    body: list[Token]
    routine: Token | None = None
    """The routine (PROC, FUNC, TRAP) a header in front of the statement starts: its name."""
    params: list[Token] = field(default_factory=list)
    """That routine's parameter list, between its parentheses."""
    record: bool | None = None
    """True where a RECORD's field list starts (its fields are no statements), False where ENDRECORD ends it."""


def split(run: list[Token]) -> Split:
    out = Split([], [])
    k = 0
    while k < len(run):
        nxt = _past_header(run, k, out)
        if nxt == k:
            break
        k = nxt
    out.header, out.body = run[:k], run[k:]
    return out


def _closing(run: list[Token], k: int) -> int:
    """The index after the parenthesis matching the one at k (k itself where none opens there)."""
    if k >= len(run) or not run[k].is_("op", "("):
        return k
    depth = 0
    for j in range(k, len(run)):
        depth += run[j].is_("op", "(") - run[j].is_("op", ")")
        if depth == 0:
            return j + 1
    return len(run)


def _past_header(run: list[Token], k: int, out: Split) -> int:
    """The index after one block header starting at k (k where the statement starts there)."""
    tok = run[k]
    if _percents(run, k):
        # The `%%% VERSION:1 LANGUAGE:ENGLISH %%%` header of a saved .mod: no late-bound call
        return next((j + 3 for j in range(k + 3, len(run)) if _percents(run, j)), len(run))
    if tok.kind != "name":
        return k
    word = tok.text.lower()
    nxt = run[k + 1] if k + 1 < len(run) else None
    if word in ("local", "task"):
        # LOCAL PROC, LOCAL RECORD: a header; LOCAL PERS ...: a declaration, the statement
        return k + 1 if nxt is not None and nxt.text.lower() in (*_ROUTINES, "record") else k
    if word in _ROUTINES or word in ("module", "record"):
        return _routine_header(run, k, word, out)
    if word in _BLOCK_WORDS:
        out.record = False if word == "endrecord" else out.record
        return _closing(run, k + 1) if word == "error" else k + 1
    if word in _CONDITION_ENDS:
        return _condition_end(run, k, word)
    if word == "case" or (word == "default" and nxt is not None and nxt.is_("op", ":")):
        colon = next((j for j in range(k + 1, len(run)) if run[j].is_("op", ":")), len(run) - 1)
        return colon + 1
    if nxt is not None and nxt.is_("op", ":"):
        return k + 2  # a label (`Calculate:`): `:=` is one token, so a lone `:` after a name is a label
    return k


def _percents(run: list[Token], k: int) -> bool:
    return all(j < len(run) and run[j].is_("op", "%") for j in range(k, k + 3))


def _routine_header(run: list[Token], k: int, word: str, out: Split) -> int:
    """`MODULE m (SYSMODULE)`, `PROC p(...)`, `FUNC num f(...)`, `TRAP t`, `RECORD r`: the index after it."""
    j = k + 1 + (word == "func")  # a FUNC names its type first
    if j >= len(run):
        return len(run)
    if word == "record":
        out.record = True
        return j + 1
    end = _closing(run, j + 1)
    if word in _ROUTINES:
        out.routine, out.params = run[j], run[j + 2 : end - 1] if end > j + 1 else []
    return end


def _condition_end(run: list[Token], k: int, word: str) -> int:
    """After `IF c THEN`, `WHILE c DO`, `FOR i FROM a TO b DO`, `TEST x` (up to its CASE); a compact IF's
    statement starts at the first name after a whole operand (`IF reg1 > 5 Stop;`, `IF (ok) MyProc;`)."""
    depth = 0
    for j in range(k + 1, len(run)):
        tok = run[j]
        depth += tok.kind == "op" and tok.text in "([{"
        depth -= tok.kind == "op" and tok.text in ")]}"
        if depth == 0 and tok.kind == "name" and tok.text.lower() in _CONDITION_ENDS[word]:
            return j + (word != "test")
    if word not in ("if", "elseif"):
        return len(run)
    for j in range(k + 2, len(run)):
        prev, tok = run[j - 1], run[j]
        operand = prev.kind in ("name", "number", "string") or prev.is_("op", ")") or prev.is_("op", "}")
        operand &= prev.text.lower() not in _OPERATORS
        if operand and ((tok.kind == "name" and tok.text.lower() not in _OPERATORS) or tok.is_("op", "%")):
            return j
    return len(run)


def path_end(body: list[Token]) -> int | None:
    """The index of `:=` where the statement assigns a datum or a part of one (`w.uframe.trans :=`,
    `p{2} :=`); None where it is no assignment."""
    j = 1
    while j < len(body):
        tok = body[j]
        if tok.is_("op", ":="):
            return j
        if tok.is_("op", ".") and j + 1 < len(body) and body[j + 1].kind == "name":
            j += 2
        elif tok.is_("op", "{"):
            while j < len(body) and not body[j].is_("op", "}"):
                j += 1
            j += 1
        else:
            return None
    return None


@dataclass(frozen=True)
class Param:
    name: str
    writable: bool
    """INOUT, VAR or PERS: what the routine assigns to it is the caller's datum."""
    optional: bool


def params(tokens: list[Token]) -> list[Param]:
    """A routine's parameters from its list: `[\\][INOUT|VAR|PERS] type name [{*}]`, separated by `,` (and `|`
    between alternatives of one optional parameter)."""
    out: list[Param] = []
    group: list[Token] = []
    for tok in [*tokens, None]:
        if tok is not None and not (tok.is_("op", ",") or tok.is_("op", "|")):
            group.append(tok)
            continue
        names = [t for t in group if t.kind == "name"]
        if names:
            mode = names[0].text.lower() in ("inout", "var", "pers")
            out.append(Param(names[-1].text.lower(), mode, group[0].is_("op", "\\")))
        group = []
    return out


class Layout(NamedTuple):
    """Where a motion instruction's positional arguments are (the optional ones, `\\WObj:=`, `\\T2:=`,
    `\\Weave:=`, are named and not counted)."""

    shape: str
    """Its positional arguments as the RAPID manuals name them: an error names the one missing."""
    targets: tuple[int, ...]
    """The robtargets the robot moves to (a circle's CirPoint, then its ToPoint)."""
    tool: int
    """The tooldata: its index, or counted from the end where process arguments stand between the zone and
    the tool in one version and not in another (ArcL's Weave, SpotWare's Gun): the tool is the last."""
    written: tuple[int, ...] = ()
    """The robtargets the instruction writes: SearchL's SearchPoint is where the signal came."""
    joint: bool = False
    """An axis-wise motion (ConfJ applies) rather than a linear or circular one (ConfL)."""


def _layouts() -> dict[str, Layout]:
    """The motions whose argument layout is read (the RAPID Instructions reference manual; the Arc, Spot and
    Paint options' manuals; checked against modules as robot cells save them)."""
    out: dict[str, Layout] = {}
    for kind in ("", "do", "ao", "go", "sync"):
        extra = {"": "", "sync": ", ProcName"}.get(kind, ", Signal, Value")
        out["movel" + kind] = Layout("ToPoint, Speed, Zone, Tool" + extra, (0,), 3)
        out["movej" + kind] = Layout("ToPoint, Speed, Zone, Tool" + extra, (0,), 3, joint=True)
        out["movec" + kind] = Layout("CirPoint, ToPoint, Speed, Zone, Tool" + extra, (0, 1), 4)
    out["triggl"] = Layout("ToPoint, Speed, Trigg_1, Zone, Tool", (0,), -1)
    out["triggj"] = out["triggl"]._replace(joint=True)
    out["triggc"] = Layout("CirPoint, ToPoint, Speed, Trigg_1, Zone, Tool", (0, 1), -1)
    out["trigglios"] = Layout("ToPoint, Speed, Zone, Tool", (0,), -1)
    out["triggjios"] = out["trigglios"]._replace(joint=True)
    out["searchl"] = Layout("Signal, SearchPoint, ToPoint, Speed, Tool", (2,), -1, written=(1,))
    out["searchc"] = Layout("Signal, SearchPoint, CirPoint, ToPoint, Speed, Tool", (2, 3), -1, written=(1,))
    for end in ("", "start", "end"):
        out["arcl" + end] = Layout("ToPoint, Speed, Seam, Weld, Zone, Tool", (0,), -1)
        out["arcc" + end] = Layout("CirPoint, ToPoint, Speed, Seam, Weld, Zone, Tool", (0, 1), -1)
    out["paintl"] = Layout("ToPoint, Speed, Zone, Tool", (0,), -1)
    out["paintc"] = Layout("CirPoint, ToPoint, Speed, Zone, Tool", (0, 1), -1)
    out["spotl"] = Layout("ToPoint, Speed, Spot, Tool", (0,), -1)
    out["spotj"] = out["spotl"]._replace(joint=True)
    return out


LAYOUTS = _layouts()
UNREAD_MOTIONS = frozenset(
    {"spotml", "spotmj", "displ", "dispc", "capl", "capc", "contactl", "cssdeactmovel", "calibl", "calibj"}
    | {"measurewearl", "nutl", "nutj", "paintlsig", "paintldo", "egmmovel", "egmmovec", "movepnp", "arcrepl"}
    | {"arcl1", "arcl2", "arcc1", "arcc2", "arcl1start", "arcl2start", "arcc1start", "arcc2start", "arcl1end"}
    | {"arcl2end", "arcc1end", "arcc2end", "arcadaptlstart", "arcadaptl", "arcadaptc", "arcadaptlend"}
    | {"arcadaptcend", "arcadaptrepl", "arccalclstart", "arccalcl", "arccalcc", "arccalclend", "arccalccend"}
    | {"smovel", "smoveldo", "smovelgo", "smovelsync", "smovej", "smovejdo", "smovejgo", "smovejsync"}
    | {"ssearchl", "striggl", "striggj", "daprocml", "daprocmj"}
)
"""Motions of RobotWare options (dispense, continuous application platform, multi-gun spot, Weldguide,
home-position running, ...) whose argument layout the reader has not confirmed: their robtargets are kept,
never read as data nor compensated in a tool or work object guessed."""
