; bring(?o ?p): the portable at the place, out of the briefcase.
(define (domain briefcase-tasks)
  (:requirements :typing :negative-preconditions)
  (:action bring
    :parameters (?o - portable ?p - place)
    :precondition (and (at ?o ?p) (not (in ?o)))
    :effect (and)))
