"""The ``{name:name}`` path convertor: a place's or map's name in a URL never holds a dot or a
slash (see ``app.db.names``), so ``maps/home.png`` is the picture of ``home``, never a map named
``home.png``, and ``Allow`` on a 405 lists just the routes that path can mean."""

from starlette.convertors import StringConvertor, register_url_convertor


class NameConvertor(StringConvertor):
    regex = r"[^/.]+"


register_url_convertor("name", NameConvertor())
