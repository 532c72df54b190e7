"""An argparse parser that says "did you mean" for a mistyped option, subcommand or choice."""

from __future__ import annotations

import argparse
import difflib
import re

__all__ = ["SuggestingParser", "closest"]

#: argparse's message for a value outside ``choices`` (subcommands included).
_INVALID_CHOICE = re.compile(r"invalid choice: '(?P<value>[^']*)' \(choose from (?P<choices>.*)\)")


def closest(word: str, candidates) -> str | None:
    """The candidate most like ``word`` (:func:`difflib.get_close_matches`), or None."""
    found = difflib.get_close_matches(word, list(candidates), n=1, cutoff=0.6)
    return found[0] if found else None


def _option_strings(parser: argparse.ArgumentParser) -> list[str]:
    return [s for action in parser._actions for s in action.option_strings if s.startswith("--")]


class SuggestingParser(argparse.ArgumentParser):
    """:class:`argparse.ArgumentParser` whose errors suggest the closest option or choice (its subparsers too)."""

    def error(self, message: str):
        match = _INVALID_CHOICE.search(message)
        if match:
            choices = re.findall(r"'([^']*)'", match.group("choices"))
            guess = closest(match.group("value"), choices)
            if guess:
                message = f"{message}; did you mean {guess!r}?"
        super().error(message)

    def _subparser(self, namespace) -> argparse.ArgumentParser:
        """The subparser of the command in ``namespace`` (self without one)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                name = getattr(namespace, action.dest, None)
                if name in action.choices:
                    return action.choices[name]
        return self

    def parse_args(self, args=None, namespace=None):
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            parser = self._subparser(namespace)
            unknown = [a for a in extras if a.startswith("-")]
            word = unknown[0].split("=", 1)[0] if unknown else extras[0]
            guess = closest(word, _option_strings(parser)) if unknown else None
            hint = f"; did you mean {guess}?" if guess else ""
            parser.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
        return namespace
