; Coffee at a desk: a clean mug stands there; serving it leaves it dirty (the consumption).
(define (domain mugs-tasks)
  (:requirements :typing :negative-preconditions)

  (:action serve
    :parameters (?d - place ?m - mug)
    :precondition (and (at ?m ?d) (not (dirty ?m)))
    :effect (dirty ?m)))
