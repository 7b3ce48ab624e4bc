; The restaurant of the thesis (Chapter 5, Appendix A), authored once.
; Costs are PDDL units (RL units x 100). Every number here comes from
; shared/restaurant.md; the layouts differ only in their problem files.
(define (domain restaurant)
  (:requirements :typing :equality :negative-preconditions
                 :disjunctive-preconditions :existential-preconditions
                 :universal-preconditions :conditional-effects :action-costs)
  (:types
    location room kind thing - object
    item watersource machinewater - thing   ; item = what the robot can pick
    apple washable - item
    knife plate fillable - washable
    jar vessel - fillable                   ; vessel = fillable and not a jar
    cup bowl - vessel)

  (:predicates
    (robot-at ?l - location)
    (hand-free)
    (holding ?i - item)
    (at ?t - thing ?l - location)           ; a held object is at no location
    (in ?i - item ?c - item)                ; an apple in a bowl travels with it
    (dirty ?w - washable)
    (has-water ?i - item)
    (has-coffee ?i - item)
    ; static facts of a layout
    (kind-of ?t - thing ?k - kind)
    (washing-place ?l - location)
    (cutting-place ?l - location)
    (wash-ready ?l - location)
    (brews-at ?m - machinewater ?l - location))

  (:functions
    (total-cost) - number
    (move-cost ?from ?to - location) - number)

  (:action move
    :parameters (?from ?to - location)
    :precondition (and (robot-at ?from) (not (= ?from ?to)))
    :effect (and (not (robot-at ?from)) (robot-at ?to)
                 (increase (total-cost) (move-cost ?from ?to))))

  (:action pick
    :parameters (?i - item ?l - location)
    :precondition (and (hand-free) (robot-at ?l) (at ?i ?l))
    :effect (and (not (hand-free)) (holding ?i) (not (at ?i ?l))
                 (increase (total-cost) 100)))

  (:action place
    :parameters (?i - item ?l - location)
    :precondition (and (holding ?i) (robot-at ?l))
    :effect (and (hand-free) (not (holding ?i)) (at ?i ?l)
                 (increase (total-cost) 100)))

  (:action wash
    :parameters (?w - washable ?l - location)
    :precondition (and (robot-at ?l) (washing-place ?l) (at ?w ?l) (dirty ?w))
    :effect (and (not (dirty ?w)) (not (has-water ?w)) (not (has-coffee ?w))
                 (increase (total-cost) 200)))

  (:action fill
    :parameters (?f - fillable ?s - watersource ?l - location)
    :precondition (and (robot-at ?l) (at ?s ?l) (holding ?f) (not (dirty ?f))
                       (not (has-water ?f)) (not (has-coffee ?f)))
    :effect (and (has-water ?f) (increase (total-cost) 1000)))

  (:action drain
    :parameters (?f - fillable ?s - watersource ?l - location)
    :precondition (and (robot-at ?l) (at ?s ?l) (holding ?f) (has-water ?f))
    :effect (and (not (has-water ?f)) (increase (total-cost) 50)))

  ; Pouring water back into the coffee machine restores its water.
  (:action pour
    :parameters (?f - fillable ?m - machinewater ?l - location)
    :precondition (and (robot-at ?l) (brews-at ?m ?l) (holding ?f)
                       (or (has-water ?f) (has-coffee ?f)))
    :effect (and (not (has-water ?f)) (not (has-coffee ?f))
                 (when (has-water ?f) (at ?m ?l))
                 (increase (total-cost) 200)))

  (:action make-coffee
    :parameters (?v - vessel ?m - machinewater ?l - location)
    :precondition (and (robot-at ?l) (at ?m ?l) (at ?v ?l) (not (dirty ?v))
                       (not (has-water ?v)) (not (has-coffee ?v)))
    :effect (and (has-coffee ?v) (dirty ?v) (not (at ?m ?l))
                 (increase (total-cost) 50)))

  (:action make-fruit-bowl
    :parameters (?a - apple ?b - bowl ?k - knife ?l - location)
    :precondition (and (robot-at ?l) (cutting-place ?l) (holding ?k) (not (dirty ?k))
                       (at ?a ?l) (at ?b ?l) (not (dirty ?b))
                       (not (has-water ?b)) (not (has-coffee ?b)))
    :effect (and (not (at ?a ?l)) (in ?a ?b) (dirty ?k) (dirty ?b)
                 (increase (total-cost) 100)))

  ; The jar is not used up: one fill serves every later refill.
  (:action refill-water
    :parameters (?f - fillable ?j - jar ?l - location)
    :precondition (and (robot-at ?l) (holding ?f) (not (dirty ?f))
                       (not (has-water ?f)) (not (has-coffee ?f))
                       (at ?j ?l) (has-water ?j))
    :effect (and (has-water ?f) (increase (total-cost) 50))))
