"""The error a bad spec raises. Kept apart from the schema so that catching it is cheap."""


class SpecError(ValueError):
    """A spec could not be loaded; ``problems`` lists one message per bad field."""

    def __init__(self, source: str, problems: list[str]):
        self.source = source
        self.problems = problems
        super().__init__(f"{source}: " + "; ".join(problems))
