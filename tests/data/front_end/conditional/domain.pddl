; Conditional effects without :action-costs (front-end test): the briefcase carries whatever is
; in it (forall / when), and every action costs 1, so a cost is a plan length.
(define (domain briefcase)
  (:requirements :typing :conditional-effects :negative-preconditions)
  (:types place portable)
  (:predicates (case-at ?p - place) (at ?o - portable ?p - place) (in ?o - portable))

  (:action move
    :parameters (?from ?to - place)
    :precondition (and (case-at ?from) (not (= ?from ?to)))
    :effect (and (case-at ?to) (not (case-at ?from))
                 (forall (?o - portable)
                   (when (in ?o) (and (at ?o ?to) (not (at ?o ?from)))))))

  (:action put-in
    :parameters (?o - portable ?p - place)
    :precondition (and (case-at ?p) (at ?o ?p) (not (in ?o)))
    :effect (in ?o))

  (:action take-out
    :parameters (?o - portable)
    :precondition (in ?o)
    :effect (not (in ?o))))
