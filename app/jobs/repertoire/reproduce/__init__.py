"""The repertoire's benches and doc generators; no runtime module of the kind imports them
(the kind's ``bench`` hook reaches them through ``Deferred``)."""
